#include "route_table.h"

#include <algorithm>
#include <string_view>

namespace arscout::ingest {
namespace {

bool path_matches(const ApiRoute& route, const HttpRequest& request) {
  if (route.pattern.empty()) return route.matches && route.matches(request);
  return pattern_matches(route.pattern, request.path);
}

bool takes(const ApiRoute& route, const std::string& method) {
  return route.methods.empty() ||
         std::find(route.methods.begin(), route.methods.end(), method) !=
             route.methods.end();
}

int rank(Role role) {
  switch (role) {
    case Role::kPlanner:
      return 0;
    case Role::kScout:
      return 1;
    case Role::kAdmin:
      return 2;
  }
  return 0;
}

}  // namespace

bool pattern_matches(const std::string& pattern, const std::string& path,
                     std::string* rest) {
  if (pattern.empty() || pattern[0] != '/' || path.empty() || path[0] != '/')
    return false;
  std::size_t p = 1, q = 1;  // the current segment of each
  while (true) {
    std::size_t p_end = pattern.find('/', p);
    const bool last = p_end == std::string::npos;
    if (last) p_end = pattern.size();
    const std::string_view want(pattern.data() + p, p_end - p);
    if (last && want == "*") {
      if (rest) *rest = path.substr(q);
      return true;
    }
    std::size_t q_end = path.find('/', q);
    if (q_end == std::string::npos) q_end = path.size();
    const std::string_view got(path.data() + q, q_end - q);
    if (want == "*" ? got.empty() : got != want) return false;
    if (last || q_end == path.size()) return last && q_end == path.size();
    p = p_end + 1;
    q = q_end + 1;
  }
}

RouteChoice choose_route(const std::vector<ApiRoute>& routes,
                         const HttpRequest& request) {
  RouteChoice choice;
  auto owner = std::find_if(routes.begin(), routes.end(), [&](const auto& r) {
    return path_matches(r, request);
  });
  if (owner == routes.end()) return choice;
  choice.owner = &*owner;
  for (auto r = owner; r != routes.end(); ++r) {
    if (r != owner && (owner->pattern.empty() || r->pattern != owner->pattern))
      break;
    if (takes(*r, request.method)) {
      choice.route = &*r;
      return choice;
    }
    for (const std::string& method : r->methods)
      choice.allowed += (choice.allowed.empty() ? "" : ", ") + method;
  }
  return choice;
}

bool role_at_least(Role who, Role least) { return rank(who) >= rank(least); }

std::string method_label(const std::string& method) {
  for (const char* known :
       {"GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS"})
    if (method == known) return method;
  return "OTHER";
}

std::string route_label(const RouteChoice& choice, const std::string& method) {
  if (!choice.owner) return "other";
  const ApiRoute& route = choice.route ? *choice.route : *choice.owner;
  if (!route.name.empty()) return route.name;
  if (route.pattern.empty()) return "other";  // nothing to name it by
  return method_label(method) + " " + route.pattern;
}

}  // namespace arscout::ingest
