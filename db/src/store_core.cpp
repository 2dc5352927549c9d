#include "store_core.h"

#include <chrono>
#include <cmath>
#include <ostream>
#include <random>
#include <regex>

#include "arscout/db/errors.h"
#include "arscout/db/path.h"
#include "arscout/util/geodesy.h"
#include "arscout/util/sha256.h"

namespace arscout::db::internal {
namespace {

bool is_name_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
         (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
}

bool is_short_name(std::string_view s, std::size_t max) {
  if (s.empty() || s.size() > max) return false;
  for (char c : s)
    if (!is_name_char(c)) return false;
  return true;
}

[[noreturn]] void invalid_document(const std::string& path,
                                   const std::string& why) {
  throw StoreError(ErrorCode::kInvalidDocument,
                   "invalid document " + path + ": " + why);
}

void validate_attrs(const std::string& path, const Json& attrs) {
  if (!attrs.is_object())
    invalid_document(path,
                     std::string("attributes must be a JSON object, got ") +
                         attrs.type_name());
  std::size_t bytes = 0;
  try {
    bytes = attrs.dump().size();
  } catch (const Json::exception& e) {  // e.g. a string of invalid UTF-8
    invalid_document(path,
                     std::string("attributes cannot be stored: ") + e.what());
  }
  if (bytes > kMaxAttributesBytes)
    throw StoreError(ErrorCode::kTooLarge,
                     "attributes of " + path + " are " + std::to_string(bytes) +
                         " bytes, over the limit of " +
                         std::to_string(kMaxAttributesBytes));
}

void validate_blob_refs(WriteTxn& txn, const std::string& path,
                        const BlobRefs& refs) {
  if (refs.size() > kMaxBlobRefs)
    invalid_document(
        path, "more than " + std::to_string(kMaxBlobRefs) + " blob references");
  for (const auto& [name, hash] : refs) {
    if (!is_short_name(name, 64))
      invalid_document(path,
                       "blob name '" + name +
                           "' must be 1-64 characters of A-Z a-z 0-9 . _ -");
    if (!util::is_sha256_hex(hash))
      invalid_document(path, "blob '" + name + "' hash '" + hash +
                                 "' is not 64 lower-case hex digits");
    if (!txn.blob_exists(hash))
      throw StoreError(ErrorCode::kUnknownBlob,
                       "document " + path + " refers to blob '" + name +
                           "' = " + hash + ", which is not stored");
  }
}

void check_expected(const WriteOp& op, std::int64_t current) {
  if (op.expected_version && *op.expected_version != current)
    throw ConflictError(op.path, *op.expected_version, current);
}

WriteResult apply_one(WriteTxn& txn, const WriteOp& op,
                      const std::string& author, std::int64_t now) {
  validate_path(op.path);
  if (op.expected_version && *op.expected_version < 0)
    throw StoreError(ErrorCode::kInvalidArgument,
                     "expected version of " + op.path + " is negative");
  bool deleted = false;
  std::optional<Document> row = txn.load_row(op.path, &deleted);
  const bool live = row && !deleted;
  const std::int64_t current = live ? row->version : 0;
  check_expected(op, current);

  Document doc;
  doc.path = op.path;
  doc.author = author;
  doc.updated_us = now;
  doc.version = (row ? row->version : 0) + 1;
  doc.created_us = live ? row->created_us : now;
  switch (op.type) {
    case OpType::kPut:
      if (!is_short_name(op.kind, kMaxKindLength))
        invalid_document(op.path, "kind '" + op.kind +
                                      "' must be 1-64 characters of "
                                      "A-Z a-z 0-9 . _ -");
      validate_attrs(op.path, op.attrs);
      doc.kind = op.kind;
      doc.attrs = op.attrs;
      doc.blobs = op.blobs.value_or(BlobRefs{});
      validate_blob_refs(txn, op.path, doc.blobs);
      break;
    case OpType::kPatch:
      if (!live)
        throw StoreError(ErrorCode::kNotFound,
                         "cannot patch " + op.path + ": no such document");
      if (!op.attrs.is_object())
        invalid_document(op.path, "a merge patch must be a JSON object");
      doc.kind = row->kind;
      doc.attrs = row->attrs;
      doc.attrs.merge_patch(op.attrs);
      validate_attrs(op.path, doc.attrs);
      doc.blobs = op.blobs ? *op.blobs : row->blobs;
      if (op.blobs) validate_blob_refs(txn, op.path, doc.blobs);
      break;
    case OpType::kDelete:
      if (!live)
        throw StoreError(ErrorCode::kNotFound,
                         "cannot delete " + op.path + ": no such document");
      doc.kind = row->kind;
      doc.created_us = row->created_us;
      break;
  }
  doc.seq = txn.next_seq();
  txn.store_row(doc, op.type == OpType::kDelete);
  txn.append_change(Change{doc.seq, doc.path, op.type, doc.version, doc.kind,
                           doc.author, now});
  return WriteResult{doc.path, doc.version, doc.seq};
}

const Json* find_dotted(const Json& attrs, const std::string& key) {
  const Json* node = &attrs;
  std::size_t start = 0;
  while (true) {
    std::size_t dot = key.find('.', start);
    std::string part = key.substr(
        start, dot == std::string::npos ? std::string::npos : dot - start);
    if (!node->is_object()) return nullptr;
    auto it = node->find(part);
    if (it == node->end()) return nullptr;
    node = &*it;
    if (dot == std::string::npos) return node;
    start = dot + 1;
  }
}

constexpr double kEarthRadiusM = util::kEarthMeanRadiusM;
constexpr double kPi = 3.14159265358979323846;
double radians(double deg) { return deg * kPi / 180.0; }

}  // namespace

std::int64_t now_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::vector<WriteResult> apply_ops(WriteTxn& txn,
                                   const std::vector<WriteOp>& ops,
                                   const std::string& default_author) {
  std::vector<WriteResult> results;
  results.reserve(ops.size());
  const std::int64_t now = now_us();
  for (std::size_t i = 0; i < ops.size(); ++i) {
    const WriteOp& op = ops[i];
    const std::string& author = op.author.empty() ? default_author : op.author;
    try {
      results.push_back(apply_one(txn, op, author, now));
    } catch (const ConflictError&) {
      throw;  // keeps its type; the path already says which op
    } catch (const StoreError& e) {
      if (ops.size() == 1) throw;
      throw StoreError(e.code(), "batch operation " + std::to_string(i) + " (" +
                                     to_string(op.type) + "): " + e.what());
    }
  }
  return results;
}

void validate_query(const Query& query) {
  validate_pattern(query.pattern);
  for (const auto& [key, value] : query.equals) {
    static const std::regex key_re("[A-Za-z0-9_-]+(\\.[A-Za-z0-9_-]+)*");
    if (!std::regex_match(key, key_re))
      throw StoreError(ErrorCode::kInvalidArgument,
                       "attribute key '" + key +
                           "' must be dotted names of A-Z a-z 0-9 _ -");
  }
  if (query.near) {
    const GeoRadius& g = *query.near;
    if (!(std::abs(g.lat) <= 90) || !(std::abs(g.lon) <= 180))
      throw StoreError(ErrorCode::kInvalidArgument,
                       "radius centre is outside WGS84 latitude/longitude");
    if (!(g.radius_m >= 0) || !std::isfinite(g.radius_m))
      throw StoreError(ErrorCode::kInvalidArgument,
                       "radius must be a finite number of metres >= 0");
  }
}

bool matches_query(const Query& query, const Document& doc) {
  if (!matches_pattern(query.pattern, doc.path)) return false;
  for (const auto& [key, value] : query.equals) {
    const Json* found = find_dotted(doc.attrs, key);
    if (found == nullptr || *found != value) return false;
  }
  if (query.near) {
    auto pos = gps_position(doc.attrs);
    if (!pos) return false;
    const GeoRadius& g = *query.near;
    if (util::great_circle_m(g.lat, g.lon, pos->first, pos->second) >
        g.radius_m)
      return false;
  }
  return true;
}

std::optional<std::pair<double, double>> gps_position(const Json& attrs) {
  if (!attrs.is_object()) return std::nullopt;
  auto gps = attrs.find("gps");
  if (gps == attrs.end() || !gps->is_object()) return std::nullopt;
  auto lat = gps->find("lat");
  auto lon = gps->find("lon");
  if (lat == gps->end() || lon == gps->end() || !lat->is_number() ||
      !lon->is_number())
    return std::nullopt;
  double la = lat->get<double>(), lo = lon->get<double>();
  if (!(std::abs(la) <= 90) || !(std::abs(lo) <= 180)) return std::nullopt;
  return std::make_pair(la, lo);
}

LatLonBox bounding_box(const GeoRadius& near) {
  // Slightly generous so the exact distance test is the only one that bites.
  double dlat = (near.radius_m * 1.01 + 1) / kEarthRadiusM * 180 / kPi;
  LatLonBox box{near.lat - dlat, near.lat + dlat, -180, 180};
  double cos_lat = std::cos(radians(std::min(89.0, std::abs(near.lat) + dlat)));
  if (box.max_lat < 90 && box.min_lat > -90 && cos_lat > 1e-6) {
    double dlon = dlat / cos_lat;
    if (near.lon - dlon > -180 && near.lon + dlon < 180) {
      box.min_lon = near.lon - dlon;
      box.max_lon = near.lon + dlon;
    }
  }
  return box;
}

std::vector<Document> collect_pages(
    const std::function<std::vector<Document>(const std::string&, std::size_t)>&
        fetch_page,
    const std::function<bool(const Document&)>& keep, std::size_t limit) {
  std::vector<Document> out;
  const std::size_t page = std::clamp<std::size_t>(limit * 2, 64, 2048);
  std::string after;
  while (out.size() < limit) {
    std::vector<Document> rows = fetch_page(after, page);
    for (Document& d : rows) {
      if (keep(d)) out.push_back(std::move(d));
      if (out.size() == limit) break;
    }
    if (rows.size() < page) break;
    after = rows.back().path;
  }
  return out;
}

std::vector<Change> collect_changes(
    const std::function<std::vector<Change>(std::int64_t, std::size_t)>&
        fetch_page,
    std::int64_t since, std::string_view pattern, std::size_t limit) {
  std::vector<Change> out;
  const std::size_t page = std::clamp<std::size_t>(limit, 64, 4096);
  std::int64_t after = since;
  while (out.size() < limit) {
    std::vector<Change> rows = fetch_page(after, page);
    for (Change& c : rows) {
      after = c.seq;
      if (matches_pattern(pattern, c.path)) out.push_back(std::move(c));
      if (out.size() == limit) break;
    }
    if (rows.size() < page) break;
  }
  return out;
}

StreamedBlob stream_chunks(
    std::istream& in,
    const std::function<void(std::int64_t, std::string_view)>& write_chunk) {
  StreamedBlob result;
  util::Sha256 hash;
  std::string chunk(kBlobChunkBytes, '\0');
  while (in) {
    in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
    std::streamsize got = in.gcount();
    if (got <= 0) break;
    std::string_view piece(chunk.data(), static_cast<std::size_t>(got));
    hash.update(piece);
    write_chunk(result.chunks++, piece);
    result.size += got;
  }
  if (in.bad())
    throw StoreError(ErrorCode::kInvalidArgument,
                     "reading the blob's input failed");
  result.sha256 = hash.hex_digest();
  return result;
}

void write_blob_range(
    const BlobInfo& info, std::int64_t offset, std::int64_t length,
    const std::function<std::string(std::int64_t)>& read_chunk,
    std::ostream& out) {
  if (offset < 0 || offset > info.size)
    throw StoreError(ErrorCode::kInvalidArgument,
                     "offset " + std::to_string(offset) + " is outside blob " +
                         info.sha256 + " of " + std::to_string(info.size) +
                         " bytes");
  if (length < 0) length = info.size - offset;
  if (length > info.size - offset)
    throw StoreError(ErrorCode::kInvalidArgument,
                     "range of " + std::to_string(length) + " bytes at " +
                         std::to_string(offset) +
                         " runs past the end of blob " + info.sha256);
  const auto chunk = static_cast<std::int64_t>(kBlobChunkBytes);
  std::int64_t pos = offset, end = offset + length;
  while (pos < end) {
    std::int64_t index = pos / chunk;
    std::string data = read_chunk(index);
    std::int64_t from = pos - index * chunk;
    std::int64_t n = std::min<std::int64_t>(
        end - pos, static_cast<std::int64_t>(data.size()) - from);
    if (n <= 0)
      throw StoreError(
          ErrorCode::kInternal,
          "blob " + info.sha256 + " is missing chunk " + std::to_string(index));
    out.write(data.data() + from, n);
    pos += n;
  }
}

std::string new_upload_id() {
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  char buf[40];
  std::snprintf(buf, sizeof buf, "upload-%016llx%08llx",
                static_cast<unsigned long long>(rng()),
                static_cast<unsigned long long>(now_us() & 0xffffffff));
  return buf;
}

std::string blob_refs_to_text(const BlobRefs& refs) {
  return Json(refs).dump();
}

BlobRefs blob_refs_from_text(std::string_view text) {
  if (text.empty()) return {};
  Json j = Json::parse(text, nullptr, false);
  BlobRefs refs;
  if (!j.is_object()) return refs;
  for (auto& [k, v] : j.items())
    if (v.is_string()) refs[k] = v.get<std::string>();
  return refs;
}

OpType op_from_string(std::string_view text) {
  if (text == "patch") return OpType::kPatch;
  if (text == "delete") return OpType::kDelete;
  return OpType::kPut;
}

}  // namespace arscout::db::internal
