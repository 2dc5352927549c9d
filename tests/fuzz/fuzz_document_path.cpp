// Document paths and patterns (db/include/arscout/db/path.h), the first
// thing every document request is checked against. The input's first line
// is read as a pattern, the rest (or the same line) as a path. Refusals must
// be StoreError(kInvalidPath); whatever is accepted must keep the header's
// promises about splitting, parents, leaves and matching.
#include <string>
#include <string_view>
#include <vector>

#include "arscout/db/errors.h"
#include "arscout/db/path.h"
#include "fuzz_support.h"

namespace {

using arscout::fuzz::check;
namespace db = arscout::db;

template <typename Validate>
bool accepted(Validate validate) {
  try {
    validate();
    return true;
  } catch (const db::StoreError& e) {
    check(e.code() == db::ErrorCode::kInvalidPath,
          "a refusal is StoreError(kInvalidPath)");
    return false;
  }
}

bool valid_path(std::string_view path) {
  return accepted([&] { db::validate_path(path); });
}

bool valid_pattern(std::string_view pattern) {
  return accepted([&] { db::validate_pattern(pattern); });
}

void check_path(std::string_view path) {
  const bool ok = valid_path(path);
  check(accepted([&] { db::validate_path(path, true); }) == (ok || path == "/"),
        "root_ok admits exactly the root besides the valid paths");
  if (!ok) return;

  check(valid_pattern(path), "a valid path is a valid pattern");
  const std::vector<std::string_view> segments = db::split_path(path);
  check(!segments.empty() && segments.size() <= db::kMaxPathDepth,
        "a valid path has 1..kMaxPathDepth segments");
  check(db::path_depth(path) == segments.size(), "depth counts the segments");
  std::string joined;
  for (std::string_view s : segments) {
    check(!s.empty() && s.size() <= db::kMaxSegmentLength,
          "segments are 1..kMaxSegmentLength long");
    joined += "/";
    joined += s;
  }
  check(joined == path, "the segments join back to the path");

  const std::string parent = db::parent_path(path);
  const std::string_view leaf = db::leaf_name(path);
  check(leaf == segments.back(), "the leaf is the last segment");
  if (segments.size() == 1) {
    check(parent == "/", "a top-level path's parent is the root");
    check(db::matches_pattern("/*", path), "/* matches a top-level path");
  } else {
    check(valid_path(parent), "a parent is a valid path");
    check(db::path_depth(parent) + 1 == segments.size(),
          "a parent is one segment shorter");
    check(parent + "/" + std::string(leaf) == path,
          "parent and leaf make the path");
    check(db::matches_pattern(parent + "/*", path),
          "parent/* matches the path");
    check(db::matches_pattern(parent + "/**", path),
          "parent/** matches the path");
    check(!db::matches_pattern(parent, path),
          "the parent as a pattern does not match its child");
  }
  check(db::matches_pattern(path, path), "a path matches itself");
  check(db::matches_pattern("/**", path), "/** matches every path");
  check(!db::matches_pattern("/", path), "/ matches only the root");
  check(db::pattern_literal_prefix(path) == path,
        "a pattern without wildcards is its own literal prefix");
  const std::string below = std::string(path) + "/**";
  if (valid_pattern(below))
    check(db::matches_pattern(below, path), "path/** matches the path itself");
}

void check_match(std::string_view pattern, std::string_view path) {
  const bool matches = db::matches_pattern(pattern, path);
  if (pattern.find('*') == std::string_view::npos)
    check(matches == (pattern == path),
          "a pattern without wildcards matches only itself");
  if (matches)
    check(path.starts_with(db::pattern_literal_prefix(pattern)),
          "every match starts with the pattern's literal prefix");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  const std::string_view input = arscout::fuzz::as_text(data, size);
  const std::size_t newline = input.find('\n');
  const std::string_view pattern = input.substr(0, newline);
  const std::string_view path =
      newline == std::string_view::npos ? pattern : input.substr(newline + 1);
  check_path(path);
  if (valid_pattern(pattern) && valid_path(path)) check_match(pattern, path);
  return 0;
}
