#include "arscout/db/path.h"

#include "arscout/db/errors.h"

namespace arscout::db {
namespace {

bool is_segment_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
         (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
}

[[noreturn]] void fail(std::string_view what, std::string_view text,
                       const std::string& why) {
  std::string shown(text.substr(0, 80));
  if (text.size() > 80) shown += "...";
  throw StoreError(
      ErrorCode::kInvalidPath,
      std::string("invalid ") + std::string(what) + " '" + shown + "': " + why);
}

// Checks the shape shared by paths and patterns; `wildcard_ok` lets "*" and a
// final "**" through.
void validate(std::string_view text, std::string_view what, bool root_ok,
              bool wildcard_ok) {
  if (text.empty()) fail(what, text, "it is empty");
  if (text.front() != '/') fail(what, text, "it must start with '/'");
  if (text.size() > kMaxPathLength)
    fail(what, text,
         "it is longer than " + std::to_string(kMaxPathLength) + " characters");
  if (text == "/") {
    if (!root_ok) fail(what, text, "the root '/' cannot be written");
    return;
  }
  if (text.back() == '/') fail(what, text, "it ends with '/'");
  auto segments = split_path(text);
  if (segments.size() > kMaxPathDepth)
    fail(what, text,
         "it has more than " + std::to_string(kMaxPathDepth) + " segments");
  for (std::size_t i = 0; i < segments.size(); ++i) {
    std::string_view s = segments[i];
    std::string pos = "segment " + std::to_string(i + 1);
    if (s.empty()) fail(what, text, pos + " is empty ('//')");
    if (wildcard_ok && s == "*") continue;
    if (wildcard_ok && s == "**") {
      if (i + 1 != segments.size())
        fail(what, text, "'**' may only be the last segment");
      continue;
    }
    if (s == "." || s == "..")
      fail(what, text, pos + " is '" + std::string(s) + "'");
    if (s.size() > kMaxSegmentLength)
      fail(what, text,
           pos + " is longer than " + std::to_string(kMaxSegmentLength));
    for (char c : s) {
      if (!is_segment_char(c)) {
        std::string shown =
            (c >= 0x20 && c < 0x7f)
                ? std::string("'") + c + "'"
                : "byte " + std::to_string(static_cast<unsigned char>(c));
        fail(what, text,
             pos + " contains " + shown + " (allowed: A-Z a-z 0-9 . _ -)");
      }
    }
  }
}

bool match_from(const std::vector<std::string_view>& pat, std::size_t pi,
                const std::vector<std::string_view>& segs, std::size_t si) {
  for (; pi < pat.size(); ++pi, ++si) {
    if (pat[pi] == "**") return true;  // validated: always last
    if (si >= segs.size()) return false;
    if (pat[pi] != "*" && pat[pi] != segs[si]) return false;
  }
  return si == segs.size();
}

}  // namespace

void validate_path(std::string_view path, bool root_ok) {
  validate(path, "path", root_ok, false);
}

void validate_pattern(std::string_view pattern) {
  validate(pattern, "pattern", true, true);
}

std::vector<std::string_view> split_path(std::string_view path) {
  std::vector<std::string_view> out;
  if (path.size() <= 1) return out;
  std::size_t start = 1;
  while (true) {
    std::size_t slash = path.find('/', start);
    if (slash == std::string_view::npos) {
      out.push_back(path.substr(start));
      return out;
    }
    out.push_back(path.substr(start, slash - start));
    start = slash + 1;
  }
}

std::size_t path_depth(std::string_view path) {
  return split_path(path).size();
}

std::string parent_path(std::string_view path) {
  std::size_t slash = path.rfind('/');
  if (slash == 0 || slash == std::string_view::npos) return "/";
  return std::string(path.substr(0, slash));
}

std::string_view leaf_name(std::string_view path) {
  return path.substr(path.rfind('/') + 1);
}

bool matches_pattern(std::string_view pattern, std::string_view path) {
  if (pattern == "/") return path == "/";
  return match_from(split_path(pattern), 0, split_path(path), 0);
}

std::string pattern_literal_prefix(std::string_view pattern) {
  std::size_t star = pattern.find('*');
  if (star == std::string_view::npos) return std::string(pattern);
  std::string_view prefix = pattern.substr(0, star);
  if (!prefix.empty() && prefix.back() == '/') prefix.remove_suffix(1);
  return std::string(prefix);
}

}  // namespace arscout::db
