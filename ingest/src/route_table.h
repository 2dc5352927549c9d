// Finding a request's route in a table of ApiRoute (server.h): path
// patterns, the choice by method, roles and metrics labels. Api's dispatch,
// its check before a body is read and its metrics labels all ask here, so
// they cannot disagree about which route a request is.
#pragma once

#include <string>
#include <vector>

#include "arscout/http/http_types.h"
#include "arscout/ingest/auth.h"
#include "arscout/ingest/server.h"

namespace arscout::ingest {

// Whether `path` matches `pattern` (ApiRoute::pattern); *rest, where
// given, gets what a last "*" matched.
bool pattern_matches(const std::string& pattern, const std::string& path,
                     std::string* rest = nullptr);

struct RouteChoice {
  const ApiRoute* owner = nullptr;  // the first route matching the path
  const ApiRoute* route = nullptr;  // of the owner's group, the method's
  std::string allowed;  // where no route takes the method: for Allow
};
RouteChoice choose_route(const std::vector<ApiRoute>& routes,
                         const HttpRequest& request);

// planner < scout < admin: scouts may upload, planners only read.
bool role_at_least(Role who, Role least);

// A method as a metrics label: one of a fixed set, so that a client cannot
// grow /metrics by inventing methods (any token is a valid HTTP method).
std::string method_label(const std::string& method);
// The metrics label of the chosen route for a request with `method`, or
// "other" where no route matched.
std::string route_label(const RouteChoice& choice, const std::string& method);

}  // namespace arscout::ingest
