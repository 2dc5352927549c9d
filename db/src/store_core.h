// The part of the store that is the same on every backend: what a write means
// (validation, version checks, merge patch, the change it logs), the exact
// query predicate, blob streaming, and the shared Store members. A backend
// only moves rows; it never decides.
#pragma once

#include <cstdint>
#include <functional>
#include <istream>
#include <optional>
#include <streambuf>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "arscout/db/document.h"
#include "arscout/db/store.h"

namespace arscout::db::internal {

// Size of the rows a blob is stored in. A reader or writer holds one at most.
inline constexpr std::size_t kBlobChunkBytes = 1 << 20;

// Row-level access inside one write transaction. The transaction holds the
// store's write lock from its start, so loads see every earlier commit and
// sequence numbers are handed out in commit order.
class WriteTxn {
 public:
  virtual ~WriteTxn() = default;
  // The document row at path, tombstone included (Document::kind is kept,
  // attrs empty); nullopt if the path was never written.
  virtual std::optional<Document> load_row(const std::string& path,
                                           bool* deleted) = 0;
  virtual std::int64_t next_seq() = 0;
  // Inserts or replaces the row; `deleted` marks a tombstone. Replaces the
  // row's blob references by doc.blobs.
  virtual void store_row(const Document& doc, bool deleted) = 0;
  virtual void append_change(const Change& change) = 0;
  virtual bool blob_exists(const std::string& sha256) = 0;
};

std::int64_t now_us();

// Validates and applies every op through txn, in order. Throws on the first
// failure (StoreError, message prefixed with the op's index when there are
// several); the caller then rolls the transaction back.
std::vector<WriteResult> apply_ops(WriteTxn& txn,
                                   const std::vector<WriteOp>& ops,
                                   const std::string& default_author);

// Validates a query's pattern, keys and radius (throws StoreError).
void validate_query(const Query& query);
// The exact predicate of a query, applied after a backend's index narrowing.
bool matches_query(const Query& query, const Document& doc);

// attrs.gps.{lat,lon} when both are finite numbers within WGS84 ranges.
std::optional<std::pair<double, double>> gps_position(const Json& attrs);
struct LatLonBox {
  double min_lat, max_lat, min_lon, max_lon;
};
// A box containing every point within radius of the centre (longitudes may
// need two boxes near the antimeridian: the box is then widened to all).
LatLonBox bounding_box(const GeoRadius& near);

// Collects up to `limit` documents that pass `keep`, asking `fetch_page` for
// candidates in path order after a given path (exclusive; "" = from the
// start), `page` at a time, until it returns fewer than asked.
std::vector<Document> collect_pages(
    const std::function<std::vector<Document>(const std::string& after,
                                              std::size_t page)>& fetch_page,
    const std::function<bool(const Document&)>& keep, std::size_t limit);

// Same, for change-log entries with seq > since matching a pattern.
std::vector<Change> collect_changes(
    const std::function<std::vector<Change>(std::int64_t after,
                                            std::size_t page)>& fetch_page,
    std::int64_t since, std::string_view pattern, std::size_t limit);

struct StreamedBlob {
  std::string sha256;
  std::int64_t size = 0;
  std::int64_t chunks = 0;
};
// Reads `in` to EOF in kBlobChunkBytes pieces, hashing each and handing it
// to write_chunk(index, bytes) before reading the next.
StreamedBlob stream_chunks(
    std::istream& in,
    const std::function<void(std::int64_t, std::string_view)>& write_chunk);

// Writes the [offset, offset+length) slice of a chunked blob to out, reading
// one chunk at a time through read_chunk(index). Validates the range.
void write_blob_range(
    const BlobInfo& info, std::int64_t offset, std::int64_t length,
    const std::function<std::string(std::int64_t)>& read_chunk,
    std::ostream& out);

// Reads a string_view as a stream without copying it.
class ViewBuffer : public std::streambuf {
 public:
  explicit ViewBuffer(std::string_view bytes) {
    char* p = const_cast<char*>(bytes.data());
    setg(p, p, p + bytes.size());
  }
};

// A fresh random identifier for a partial upload.
std::string new_upload_id();

// Serialised forms of blob references (a JSON object), tolerant on read.
std::string blob_refs_to_text(const BlobRefs& refs);
BlobRefs blob_refs_from_text(std::string_view text);

OpType op_from_string(std::string_view text);

}  // namespace arscout::db::internal
