// Value types of the document store: documents, write operations, changes,
// queries. Plain data; the rules they must satisfy are enforced by Store.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace arscout::db {

using Json = nlohmann::json;

// Attribute size limit: the compact JSON text of a document's attributes.
inline constexpr std::size_t kMaxAttributesBytes = 1 << 20;  // 1 MiB
inline constexpr std::size_t kMaxKindLength = 64;
// The engine keeps a site's state in up to 400 content-defined parts.
inline constexpr std::size_t kMaxBlobRefs = 512;

// Named references to blobs: name ([A-Za-z0-9._-], <= 64 chars) -> SHA-256 of
// the blob's bytes as 64 lower-case hex digits. E.g. {"image": "9f86d0..."}.
using BlobRefs = std::map<std::string, std::string>;

struct Document {
  std::string path;
  std::string kind;  // short type tag, e.g. "capture"
  Json attrs = Json::object();
  BlobRefs blobs;
  std::int64_t version = 0;  // 1 on creation, +1 per write (deletes included)
  std::int64_t seq = 0;      // seq of the change that last wrote it
  std::int64_t created_us = 0;  // microseconds since the Unix epoch
  std::int64_t updated_us = 0;
  std::string author;  // writer identity of the last write
};

// Converts a document to the JSON form used by the CLI and the HTTP API:
// {"path", "kind", "attrs", "blobs", "version", "seq", "created", "updated",
//  "author"} with times as RFC 3339 UTC strings.
Json to_json(const Document& doc);

enum class OpType { kPut, kPatch, kDelete };
const char* to_string(OpType op);

// One write. expected_version: nullopt writes unconditionally; 0 requires that
// no live document exists; N > 0 requires the live document to be at version N.
struct WriteOp {
  OpType type = OpType::kPut;
  std::string path;
  std::string kind;               // put: required; patch: ignored
  Json attrs = Json::object();    // put: new attributes; patch: merge patch
  std::optional<BlobRefs> blobs;  // put: refs (none if unset); patch: replace
  std::optional<std::int64_t> expected_version;
  std::string author;  // empty: the store's default author

  static WriteOp put(std::string path, std::string kind, Json attrs,
                     std::optional<std::int64_t> expected = std::nullopt);
  static WriteOp patch(std::string path, Json merge_patch,
                       std::optional<std::int64_t> expected = std::nullopt);
  static WriteOp remove(std::string path,
                        std::optional<std::int64_t> expected = std::nullopt);
};

struct WriteResult {
  std::string path;
  std::int64_t version = 0;  // version after the write (tombstone's if delete)
  std::int64_t seq = 0;      // the change's sequence number
};

// One entry of the change log.
struct Change {
  std::int64_t seq = 0;
  std::string path;
  OpType op = OpType::kPut;
  std::int64_t version = 0;
  std::string kind;
  std::string author;
  std::int64_t time_us = 0;  // commit time, microseconds since the Unix epoch
};

Json to_json(const Change& change);

// A geographic radius query over documents carrying attrs.gps.lat/.lon
// (WGS84 degrees). Distances are great-circle on a sphere of the WGS84 mean
// radius, accurate to about 0.5 % (ample for finding nearby sites).
struct GeoRadius {
  double lat = 0;
  double lon = 0;
  double radius_m = 0;
};

struct Query {
  std::string pattern = "/**";  // path pattern, see path.h
  // Attribute equalities, all of which must hold. Keys are dotted paths into
  // attrs ("status", "gps.satellites"); values compare as JSON values.
  std::vector<std::pair<std::string, Json>> equals;
  std::optional<GeoRadius> near;
  std::size_t limit = 1000;  // at most this many, ordered by path
};

}  // namespace arscout::db
