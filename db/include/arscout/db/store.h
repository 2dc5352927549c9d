// The shared document store: a tree of versioned JSON documents, a blob store
// addressed by SHA-256, and a durable change log, behind one interface with two
// backends chosen by URL:
//
//   sqlite:PATH                 embedded, one file in WAL mode (the default)
//   postgresql://... / postgres://...   a PostgreSQL server (libpqxx)
//
// Contract, common to both backends (the conformance tests check it):
//  * Every committed write appends exactly one Change per operation to the log,
//    with a sequence number greater than every earlier one. Sequence numbers
//    are assigned in commit order and without holes: a reader that has seen
//    seq N will never later see a change with seq <= N appear.
//  * A failed write (bad input, conflict, any error in a batch) changes
//    nothing.
//  * Documents are versioned: 1 on creation, +1 on every write. A deleted
//    document stays as a tombstone, invisible to reads, so that a re-created
//    document continues the version count (a cached version never names two
//    different contents).
//  * Blobs are immutable and stored once per content; a blob can only be
//    referenced by a document after it was stored.
//
// A Store is safe to use from many threads at once. Every method may throw
// StoreError (see errors.h).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "arscout/db/document.h"
#include "arscout/db/errors.h"

namespace arscout::db {

struct OpenOptions {
  // Author recorded for writes that name none.
  std::string default_author = "arscout";
  // Idle connections kept for reads (SQLite) or for everything
  // (PostgreSQL); more are opened while more threads are busy.
  int pool_size = 8;
  // How often a subscriber looks at the log when no wake-up arrives. On
  // SQLite it is how writes by other processes are found (default 20 ms);
  // on PostgreSQL LISTEN/NOTIFY wakes subscribers and the poll is only a
  // safety net (default 500 ms).
  std::optional<std::chrono::milliseconds> poll_interval;
  // Apply pending schema migrations on open (a fresh database is initialised).
  bool migrate = true;
};

// A running subscription; destroying it (or calling stop) stops delivery.
class Subscription {
 public:
  virtual ~Subscription() = default;
  // Stops delivery and waits for an in-flight callback to return. Must not be
  // called from inside the callback.
  virtual void stop() = 0;
  // Seq of the last change handed to the callback (the `since` it started
  // from when none was delivered yet).
  virtual std::int64_t last_seq() const = 0;
  // Set once delivery ended because the callback threw; empty otherwise.
  virtual std::string error() const = 0;
};

using ChangeCallback = std::function<void(const Change&)>;

struct BlobInfo {
  std::string sha256;
  std::int64_t size = 0;
};

// A named, time-limited claim (see Store::claim_leases).
struct Lease {
  std::string name;
  std::string holder;  // empty when free
  // Until it expires by the database's clock; zero or less: expired (a free
  // lease reads as expired).
  std::chrono::milliseconds remaining{0};
  std::int64_t generation = 0;  // +1 whenever it passes to another holder
};

struct StoreStats {
  std::int64_t documents = 0;  // live documents
  std::int64_t blobs = 0;
  std::int64_t blob_bytes = 0;
  std::int64_t last_seq = 0;
};

class Store {
 public:
  // Opens (and, with options.migrate, creates or upgrades) the store at url.
  // Throws StoreError(kUnavailable) when it cannot be opened, and
  // StoreError(kInvalidArgument) for a URL of no known scheme.
  static std::unique_ptr<Store> open(const std::string& url,
                                     const OpenOptions& options = {});

  virtual ~Store() = default;
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;

  // "sqlite" or "postgresql".
  virtual std::string backend() const = 0;

  // --- documents -----------------------------------------------------------
  // The live document at path, or nullopt.
  virtual std::optional<Document> get(std::string_view path) = 0;
  // The live documents at and below path, down to max_depth levels below it
  // (0: only path itself), ordered by path. "/" reads the whole tree.
  virtual std::vector<Document> get_subtree(std::string_view path,
                                            int max_depth) = 0;
  // Live documents exactly one level below path, ordered by path.
  virtual std::vector<Document> list_children(std::string_view path) = 0;
  // Documents matching every condition of the query, ordered by path.
  virtual std::vector<Document> query(const Query& query) = 0;
  // The database's plan for the index scan behind query(), one line per
  // step (EXPLAIN / EXPLAIN QUERY PLAN), for operators and tests.
  virtual std::string explain(const Query& query) = 0;

  // Applies one write. Throws ConflictError when expected_version does not
  // hold, StoreError(kNotFound) when patching or deleting nothing.
  WriteResult write(const WriteOp& op);
  WriteResult put(const std::string& path, const std::string& kind,
                  const Json& attrs,
                  std::optional<std::int64_t> expected = std::nullopt);
  WriteResult patch(const std::string& path, const Json& merge_patch,
                    std::optional<std::int64_t> expected = std::nullopt);
  WriteResult remove(const std::string& path,
                     std::optional<std::int64_t> expected = std::nullopt);
  // Applies all operations in one transaction, or none of them: on any error
  // nothing is written and the error names the failing operation's index.
  virtual std::vector<WriteResult> batch(const std::vector<WriteOp>& ops) = 0;

  // --- blobs -----------------------------------------------------------------
  // Stores the bytes read from `in` until EOF, streaming them in chunks (never
  // more than one chunk in memory), and returns their SHA-256. The same bytes
  // stored twice are kept once.
  virtual std::string put_blob(std::istream& in) = 0;
  std::string put_blob(std::string_view bytes);
  // Stores each of `blobs` (bytes in hand) as put_blob does and returns
  // their SHA-256s in order. Blobs stored already are not written again;
  // the others are written in a few transactions rather than a few per
  // blob, each byte once (the engine saves its state as a few hundred
  // parts). A failure may leave some of them stored, never half of one.
  virtual std::vector<std::string> put_blobs(
      const std::vector<std::string_view>& blobs) = 0;
  virtual std::optional<BlobInfo> blob_info(std::string_view sha256) = 0;
  // Writes length bytes (all remaining when negative) starting at offset to
  // `out`, a chunk at a time. Throws kUnknownBlob, or kInvalidArgument for a
  // range outside the blob.
  virtual void read_blob(std::string_view sha256, std::ostream& out,
                         std::int64_t offset = 0, std::int64_t length = -1) = 0;
  std::string get_blob(std::string_view sha256);
  // Deletes blobs that no document refers to and that are older than min_age
  // (the grace period protects a blob stored just before the document that
  // will refer to it), plus abandoned partial uploads. Returns blobs deleted.
  virtual std::size_t collect_garbage(std::chrono::seconds min_age) = 0;

  // --- change log ------------------------------------------------------------
  // Up to `limit` changes with seq > since whose path matches the pattern, in
  // seq order.
  virtual std::vector<Change> changes(std::int64_t since,
                                      std::string_view pattern = "/**",
                                      std::size_t limit = 1000) = 0;
  virtual std::int64_t last_seq() = 0;
  // The seq of the last change whose path matches the pattern (0: none).
  std::int64_t last_change(std::string_view pattern);
  // Delivers every change with seq > since matching pattern to callback, in
  // order, on a thread of the subscription's own, at least once: first the
  // backlog, then new commits as they are woken (in-process notification or
  // LISTEN/NOTIFY) or found by polling. Survives lost connections by catching
  // up from the log.
  std::unique_ptr<Subscription> subscribe(std::string pattern,
                                          std::int64_t since,
                                          ChangeCallback callback);
  // Blocks until a change with seq > after may be in the log, or timeout.
  // Spurious returns are allowed; callers re-read the log.
  virtual void wait_for_change(std::int64_t after,
                               std::chrono::milliseconds timeout) = 0;

  // Subscriber checkpoints, stored as documents /checkpoints/{name}
  // (kind "checkpoint", attrs {"seq": N}). load returns 0 when none exists.
  WriteResult save_checkpoint(const std::string& name, std::int64_t seq);
  std::int64_t load_checkpoint(const std::string& name);

  // --- leases ----------------------------------------------------------------
  // Named, time-limited claims by which workers share out work: a worker
  // holds a lease while it renews it; when it stops renewing (it died), the
  // lease expires and another may take it. Expiry is judged by the database's
  // clock, so workers on different machines agree. Leases are coordination,
  // not data: they are not documents and write nothing to the change log.
  //
  // Takes, for `holder` and `ttl` from now, those of `names` that are free,
  // expired or already holder's (those are renewed), but at most `max_new`
  // that were not holder's. A name another worker is claiming at this moment
  // is skipped, never waited for (PostgreSQL: SELECT ... FOR UPDATE SKIP
  // LOCKED). Returns the names of `names` that holder holds afterwards.
  virtual std::vector<std::string> claim_leases(
      const std::vector<std::string>& names, const std::string& holder,
      std::chrono::milliseconds ttl, std::size_t max_new) = 0;
  // Extends every lease holder still holds to `ttl` from now (an expired one
  // too, while nobody took it) and returns their names, in order.
  virtual std::vector<std::string> renew_leases(
      const std::string& holder, std::chrono::milliseconds ttl) = 0;
  // Frees those of `names` (every one when empty) that holder holds.
  virtual void release_leases(const std::string& holder,
                              const std::vector<std::string>& names = {}) = 0;
  // The leases whose names start with prefix, ordered by name.
  virtual std::vector<Lease> leases(std::string_view prefix = "") = 0;

  virtual StoreStats stats() = 0;
  // Schema versions applied, in order (from the migrations table).
  virtual std::vector<int> schema_versions() = 0;

 protected:
  Store() = default;
  // How long a subscriber sleeps between looks at the log without a wake-up.
  std::chrono::milliseconds poll_interval_{50};
};

}  // namespace arscout::db
