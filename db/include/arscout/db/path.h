// Document paths and path patterns.
//
// A path is "/" followed by 1..kMaxPathDepth segments separated by "/"; each
// segment is 1..kMaxSegmentLength characters of [A-Za-z0-9._-] and is neither
// "." nor "..". The whole path is at most kMaxPathLength characters. "/" alone
// names the root, which can be read (as a subtree) but never written.
//
// A pattern is a path in which a segment may be "*" (exactly one segment) and
// whose last segment may be "**" (zero or more further segments). "/captures/*"
// matches "/captures/c1" but not "/captures" or "/captures/c1/thumb";
// "/sites/**" matches "/sites" and everything below it; "/**" matches all.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace arscout::db {

inline constexpr std::size_t kMaxPathDepth = 16;
inline constexpr std::size_t kMaxSegmentLength = 128;
inline constexpr std::size_t kMaxPathLength = 512;

// Throws StoreError(kInvalidPath) naming the rule broken; root_ok admits "/".
void validate_path(std::string_view path, bool root_ok = false);
// Throws StoreError(kInvalidPath) for a malformed pattern.
void validate_pattern(std::string_view pattern);

// Segments of a valid path ("/" has none).
std::vector<std::string_view> split_path(std::string_view path);
// Number of segments: depth("/a/b") == 2, depth("/") == 0.
std::size_t path_depth(std::string_view path);
// "/a/b" -> "/a"; "/a" -> "/". Precondition: a valid non-root path.
std::string parent_path(std::string_view path);
// Last segment: "/a/b" -> "b".
std::string_view leaf_name(std::string_view path);

// True when the valid path matches the valid pattern.
bool matches_pattern(std::string_view pattern, std::string_view path);

// A literal string that every path matching the pattern starts with: the text
// before the first wildcard, less a trailing "/" ("/sites/*/model" -> "/sites",
// "/**" -> ""). Backends use it to narrow an index range before matching
// exactly with matches_pattern.
std::string pattern_literal_prefix(std::string_view pattern);

}  // namespace arscout::db
