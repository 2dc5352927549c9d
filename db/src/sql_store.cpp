#include "sql_store.h"

#include <spdlog/spdlog.h>

#include "arscout/db/path.h"
#include "arscout/util/sha256.h"
#include "migrations.h"
#include "store_core.h"

namespace arscout::db::internal {
namespace {

// Forgets a staged upload: its chunks too unless they were just handed to
// the finished blob (`chunks_kept`).
void forget_upload(SqlSession& s, Dialect dialect, const std::string& upload_id,
                   bool chunks_kept) {
  if (!chunks_kept)
    s.execute(make_sql(dialect, "DELETE FROM blob_chunks WHERE blob_key = ?",
                       {upload_id}));
  s.execute(make_sql(dialect, "DELETE FROM blob_uploads WHERE upload_id = ?",
                     {upload_id}));
}

Document decode_document(const SqlRow& row) {
  Document d;
  d.path = row[0].value_or("");
  d.kind = row[1].value_or("");
  d.attrs = Json::parse(row[2].value_or("{}"), nullptr, false);
  if (d.attrs.is_discarded()) d.attrs = Json::object();
  d.blobs = blob_refs_from_text(row[3].value_or(""));
  d.version = to_int(row[4]);
  d.seq = to_int(row[5]);
  d.created_us = to_int(row[6]);
  d.updated_us = to_int(row[7]);
  d.author = row[8].value_or("");
  return d;
}

Change decode_change(const SqlRow& row) {
  return Change{
      to_int(row[0]), row[1].value_or(""), op_from_string(row[2].value_or("")),
      to_int(row[3]), row[4].value_or(""), row[5].value_or(""),
      to_int(row[6])};
}

// WriteTxn over a session that holds the write lock. The seq counter row is
// read once and written back by finish().
class SqlWriteTxn : public WriteTxn {
 public:
  SqlWriteTxn(SqlSession& session, Dialect dialect) : s_(session), d_(dialect) {
    // On PostgreSQL the row lock is the store's write lock (see the schema).
    auto rows = s_.query(make_sql(
        d_, d_ == Dialect::kPostgres
                ? "SELECT value FROM counters WHERE name = 'seq' FOR UPDATE"
                : "SELECT value FROM counters WHERE name = 'seq'"));
    if (rows.empty())
      throw StoreError(ErrorCode::kInternal, "counters table has no seq row");
    seq_ = to_int(rows[0][0]);
    first_seq_ = seq_;
  }

  std::optional<Document> load_row(const std::string& path,
                                   bool* deleted) override {
    auto rows =
        s_.query(make_sql(d_,
                          std::string("SELECT ") + document_columns(d_) +
                              ", deleted FROM documents WHERE path = ?",
                          {path}));
    if (rows.empty()) return std::nullopt;
    *deleted = to_int(rows[0][9]) != 0;
    return decode_document(rows[0]);
  }

  std::int64_t next_seq() override { return ++seq_; }

  void store_row(const Document& doc, bool deleted) override {
    auto pos = deleted ? std::nullopt : gps_position(doc.attrs);
    SqlParam lat = pos ? SqlParam{pos->first} : SqlParam{SqlNull{}};
    SqlParam lon = pos ? SqlParam{pos->second} : SqlParam{SqlNull{}};
    s_.execute(make_sql(
        d_,
        "INSERT INTO documents (path, parent, depth, kind, attrs, blobs, "
        "version, seq, created_us, updated_us, author, deleted, lat, lon) "
        "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) "
        "ON CONFLICT (path) DO UPDATE SET kind = excluded.kind, "
        "attrs = excluded.attrs, blobs = excluded.blobs, "
        "version = excluded.version, seq = excluded.seq, "
        "created_us = excluded.created_us, updated_us = excluded.updated_us, "
        "author = excluded.author, deleted = excluded.deleted, "
        "lat = excluded.lat, lon = excluded.lon",
        {doc.path, parent_path(doc.path),
         static_cast<std::int64_t>(path_depth(doc.path)), doc.kind,
         deleted ? std::string("{}") : doc.attrs.dump(),
         blob_refs_to_text(doc.blobs), doc.version, doc.seq, doc.created_us,
         doc.updated_us, doc.author, std::int64_t{deleted ? 1 : 0}, lat, lon}));
    s_.execute(
        make_sql(d_, "DELETE FROM blob_refs WHERE path = ?", {doc.path}));
    for (const auto& [name, hash] : doc.blobs)
      s_.execute(make_sql(d_,
                          "INSERT INTO blob_refs (path, sha256) VALUES (?, ?) "
                          "ON CONFLICT DO NOTHING",
                          {doc.path, hash}));
  }

  void append_change(const Change& c) override {
    s_.execute(make_sql(d_,
                        "INSERT INTO changes (seq, path, op, version, kind, "
                        "author, time_us) VALUES (?, ?, ?, ?, ?, ?, ?)",
                        {c.seq, c.path, std::string(to_string(c.op)), c.version,
                         c.kind, c.author, c.time_us}));
  }

  bool blob_exists(const std::string& sha256) override {
    return !s_.query(make_sql(d_, "SELECT 1 FROM blobs WHERE sha256 = ?",
                              {sha256}))
                .empty();
  }

  // The seq position, to rewind to when a batch is abandoned.
  std::int64_t position() const { return seq_; }
  void rewind(std::int64_t position) { seq_ = position; }

  // Writes the counter back; returns the last seq handed out.
  std::int64_t finish() {
    if (seq_ == first_seq_) return seq_;
    if (d_ == Dialect::kPostgres) {
      // NOTIFY is delivered at commit, in commit order: the wake-up for
      // subscribers in every process.
      s_.query(make_sql(d_,
                        "WITH bump AS (UPDATE counters SET value = ? WHERE "
                        "name = 'seq') SELECT pg_notify('arscout_changes', ?)",
                        {seq_, std::to_string(seq_)}));
    } else {
      s_.execute(make_sql(
          d_, "UPDATE counters SET value = ? WHERE name = 'seq'", {seq_}));
    }
    return seq_;
  }

 private:
  SqlSession& s_;
  Dialect d_;
  std::int64_t seq_ = 0;
  std::int64_t first_seq_ = 0;
};

constexpr std::size_t kMaxGroupBatches = 64;

// Errors about the request itself, raised before it wrote anything: the
// transaction around it is still healthy.
bool is_request_error(ErrorCode code) {
  return code != ErrorCode::kUnavailable && code != ErrorCode::kInternal;
}

void require_valid_hash(std::string_view sha256) {
  if (!util::is_sha256_hex(sha256))
    throw StoreError(ErrorCode::kInvalidArgument,
                     "blob hash '" + std::string(sha256.substr(0, 80)) +
                         "' is not 64 lower-case hex digits");
}

}  // namespace

std::int64_t to_int(const SqlValue& value) {
  if (!value || value->empty()) return 0;
  return std::stoll(*value);
}

SqlStore::SqlStore(Dialect dialect, OpenOptions options)
    : dialect_(dialect), options_(std::move(options)) {
  using std::chrono::milliseconds;
  poll_interval_ = options_.poll_interval.value_or(
      dialect == Dialect::kSqlite ? milliseconds(20) : milliseconds(500));
}

void SqlStore::migrate(const std::string& backend_name) {
  with_migration_lock([&](SqlSession& s) {
    s.execute_script(
        "CREATE TABLE IF NOT EXISTS schema_migrations (version INTEGER NOT "
        "NULL PRIMARY KEY, name TEXT NOT NULL, applied_us BIGINT NOT NULL)");
    std::int64_t current = 0;
    for (const SqlRow& r :
         s.query(make_sql(dialect_, "SELECT version FROM schema_migrations")))
      current = std::max(current, to_int(r[0]));
    auto migrations = migrations_for(backend_name);
    if (!migrations.empty() && current > migrations.back().version)
      throw StoreError(ErrorCode::kUnavailable,
                       "database schema version " + std::to_string(current) +
                           " is newer than this arscout supports (" +
                           std::to_string(migrations.back().version) + ")");
    for (const Migration& m : migrations) {
      if (m.version <= current) continue;
      spdlog::debug("event=migrate backend={} version={} file={}", backend_name,
                    m.version, m.name);
      s.execute_script(m.sql);
      s.execute(make_sql(dialect_,
                         "INSERT INTO schema_migrations (version, name, "
                         "applied_us) VALUES (?, ?, ?)",
                         {std::int64_t{m.version}, m.name, now_us()}));
    }
  });
}

std::vector<Document> SqlStore::read_documents(const SqlStatement& statement) {
  std::vector<Document> out;
  with_read([&](SqlSession& s) {
    for (const SqlRow& row : s.query(statement))
      out.push_back(decode_document(row));
  });
  return out;
}

std::vector<Document> SqlStore::query(const Query& q) {
  validate_query(q);
  DocumentFilter filter = filter_for_query(q);
  return collect_pages(
      [&](const std::string& after, std::size_t page) {
        filter.after = after;
        filter.limit = page;
        return read_documents(document_page(dialect_, filter));
      },
      [&](const Document& d) { return matches_query(q, d); }, q.limit);
}

std::string SqlStore::explain(const Query& q) {
  validate_query(q);
  DocumentFilter filter = filter_for_query(q);
  filter.limit = q.limit;
  SqlStatement st = document_page(dialect_, filter);
  const bool sqlite = dialect_ == Dialect::kSqlite;
  st.sql = (sqlite ? "EXPLAIN QUERY PLAN " : "EXPLAIN ") + st.sql;
  std::string plan;
  with_read([&](SqlSession& s) {
    for (const SqlRow& row : s.query(st))
      plan += row[sqlite ? 3 : 0].value_or("") + "\n";
  });
  return plan;
}

std::optional<Document> SqlStore::get(std::string_view path) {
  validate_path(path);
  auto docs = read_documents(
      make_sql(dialect_,
               std::string("SELECT ") + document_columns(dialect_) +
                   " FROM documents WHERE path = ? AND deleted = 0",
               {std::string(path)}));
  if (docs.empty()) return std::nullopt;
  return std::move(docs.front());
}

std::vector<Document> SqlStore::get_subtree(std::string_view path,
                                            int max_depth) {
  validate_path(path, /*root_ok=*/true);
  if (max_depth < 0)
    throw StoreError(ErrorCode::kInvalidArgument, "depth must be >= 0");
  std::string root(path);
  std::string prefix = root == "/" ? "/" : root + "/";
  DocumentFilter filter = filter_for_subtree(root, max_depth);
  return collect_pages(
      [&](const std::string& after, std::size_t page) {
        filter.after = after;
        filter.limit = page;
        return read_documents(document_page(dialect_, filter));
      },
      [&](const Document& d) {
        return d.path == root || d.path.compare(0, prefix.size(), prefix) == 0;
      },
      std::numeric_limits<std::size_t>::max());
}

std::vector<Document> SqlStore::list_children(std::string_view path) {
  validate_path(path, /*root_ok=*/true);
  return read_documents(make_sql(
      dialect_,
      std::string("SELECT ") + document_columns(dialect_) +
          " FROM documents WHERE parent = ? AND deleted = 0 ORDER BY path",
      {std::string(path)}));
}

std::vector<WriteResult> SqlStore::batch(const std::vector<WriteOp>& ops) {
  if (ops.empty()) return {};
  // Group commit: while one caller commits, the others queue; the next
  // leader commits everything queued in one transaction. Under load this
  // turns N lock hand-offs and fsyncs into one.
  PendingBatch me{&ops, {}, nullptr, false};
  std::unique_lock lock(group_mu_);
  queue_.push_back(&me);
  while (!me.done) {
    if (committing_) {
      group_cv_.wait(lock);
      continue;
    }
    committing_ = true;
    std::vector<PendingBatch*> group;
    while (!queue_.empty() && group.size() < kMaxGroupBatches) {
      group.push_back(queue_.front());
      queue_.pop_front();
    }
    lock.unlock();
    commit_group(group);
    lock.lock();
    committing_ = false;
    group_cv_.notify_all();
  }
  if (me.error) std::rethrow_exception(me.error);
  return std::move(me.results);
}

void SqlStore::commit_group(const std::vector<PendingBatch*>& group) {
  try {
    committed(apply_group(group));
  } catch (const StoreError&) {
    if (group.size() == 1) {
      group[0]->error = std::current_exception();
    } else {
      for (PendingBatch* b : group) {
        b->results.clear();
        b->error = nullptr;
        try {
          committed(apply_group({b}));
        } catch (const StoreError&) {
          b->error = std::current_exception();
        }
      }
    }
  } catch (...) {
    // Anything else is a bug or resource failure, never a half-commit (the
    // transaction rolled back): every caller of the group hears of it.
    for (PendingBatch* b : group) b->error = std::current_exception();
  }
  for (PendingBatch* b : group) b->done = true;
}

std::int64_t SqlStore::apply_group(const std::vector<PendingBatch*>& group) {
  std::int64_t last = 0;
  with_write([&](SqlSession& s) {
    SqlWriteTxn txn(s, dialect_);
    for (PendingBatch* b : group) {
      // A single op fails before it writes anything; a longer batch may
      // fail half-way and needs a savepoint to undo its earlier ops.
      const bool fenced = b->ops->size() > 1 && group.size() > 1;
      const std::int64_t mark = txn.position();
      if (fenced) s.execute_script("SAVEPOINT batch");
      try {
        b->results = apply_ops(txn, *b->ops, options_.default_author);
        if (fenced) s.execute_script("RELEASE SAVEPOINT batch");
      } catch (const StoreError& e) {
        if (!is_request_error(e.code())) throw;    // the database failed
        if (!fenced && b->ops->size() > 1) throw;  // alone: roll back all
        if (fenced) s.execute_script("ROLLBACK TO SAVEPOINT batch");
        txn.rewind(mark);
        b->results.clear();
        b->error = std::current_exception();
      }
    }
    last = txn.finish();
  });
  return last;
}

void SqlStore::stage_chunk(const std::string& upload_id, std::int64_t index,
                           std::string_view bytes) {
  with_write([&](SqlSession& s) {
    if (index == 0)
      s.execute(make_sql(dialect_,
                         "INSERT INTO blob_uploads (upload_id, started_us) "
                         "VALUES (?, ?)",
                         {upload_id, now_us()}));
    s.execute(make_sql(
        dialect_,
        "INSERT INTO blob_chunks (blob_key, idx, data) VALUES (?, ?, ?)",
        {upload_id, index, SqlBytes{bytes}}));
  });
}

std::string SqlStore::put_blob(std::istream& in) {
  const std::string upload_id = new_upload_id();
  StreamedBlob blob;
  try {
    blob = stream_chunks(in, [&](std::int64_t index, std::string_view bytes) {
      stage_chunk(upload_id, index, bytes);
    });
    with_write([&](SqlSession& s) {
      auto staged = s.query(make_sql(
          dialect_, "SELECT count(*) FROM blob_chunks WHERE blob_key = ?",
          {upload_id}));
      if (to_int(staged[0][0]) != blob.chunks)
        throw StoreError(ErrorCode::kUnavailable,
                         "upload " + upload_id +
                             " was collected before it completed; retry");
      // The same photo uploaded twice at once (a retry racing an attempt
      // whose answer was lost) reaches this point twice: the insert must not
      // fail on the second, which keeps the first's chunks.
      const bool inserted =
          s.execute(make_sql(
              dialect_,
              "INSERT INTO blobs (sha256, size, chunk_bytes, created_us) "
              "VALUES (?, ?, ?, ?) ON CONFLICT (sha256) DO NOTHING",
              {blob.sha256, blob.size,
               static_cast<std::int64_t>(kBlobChunkBytes), now_us()})) == 1;
      if (inserted)
        s.execute(make_sql(
            dialect_, "UPDATE blob_chunks SET blob_key = ? WHERE blob_key = ?",
            {blob.sha256, upload_id}));
      else
        touch_blobs(s, {blob.sha256});
      forget_upload(s, dialect_, upload_id, /*chunks_kept=*/inserted);
    });
  } catch (...) {
    // Leave nothing half-written behind where we can; GC catches the rest.
    try {
      with_write([&](SqlSession& s) {
        forget_upload(s, dialect_, upload_id, /*chunks_kept=*/false);
      });
    } catch (const StoreError&) {
    }
    throw;
  }
  return blob.sha256;
}

// Bytes in hand need no staging: a blob and its chunks are written under
// its hash in the transaction that records it, so no reader ever sees part
// of one, and no byte is written twice (staging wrote every chunk again
// when it renamed it). Transactions are kept to about kInHandTransaction
// bytes, so that other writers wait no longer than that takes; a larger
// blob is staged a chunk at a time, as a stream is.
std::vector<std::string> SqlStore::put_blobs(
    const std::vector<std::string_view>& blobs) {
  constexpr std::size_t kInHandTransaction = 8 * kBlobChunkBytes;
  std::vector<std::string> shas, held;
  std::vector<size_t> missing;
  shas.reserve(blobs.size());
  for (size_t i = 0; i < blobs.size(); ++i) {
    shas.push_back(util::sha256_hex(blobs[i]));
    if (blob_info(shas.back())) {
      held.push_back(shas.back());
      continue;
    }
    if (blobs[i].size() <= kInHandTransaction) {
      missing.push_back(i);
      continue;
    }
    // A large one is staged a chunk per transaction, as a stream is.
    ViewBuffer buffer(blobs[i]);
    std::istream in(&buffer);
    put_blob(in);
  }
  size_t next = 0;
  while (next < missing.size()) {
    size_t end = next, bytes = 0;
    while (end < missing.size() && (end == next || bytes < kInHandTransaction))
      bytes += blobs[missing[end++]].size();
    with_write([&](SqlSession& s) {
      for (size_t i = next; i < end; ++i)
        insert_blob(s, shas[missing[i]], blobs[missing[i]]);
    });
    next = end;
  }
  if (!held.empty()) with_write([&](SqlSession& s) { touch_blobs(s, held); });
  return shas;
}

// Blobs stored again count as new for the garbage collector's grace period
// (collect_garbage): a writer that stores bytes the store already holds,
// unreferenced and old, and then refers to them must not find them
// collected in between.
void SqlStore::touch_blobs(SqlSession& s,
                           const std::vector<std::string>& shas) {
  const std::int64_t now = now_us();
  for (const std::string& sha : shas)
    s.execute(make_sql(dialect_,
                       "UPDATE blobs SET created_us = ? WHERE sha256 = ? AND "
                       "created_us < ?",
                       {now, sha, now}));
}

// One whole blob under its hash, in the caller's transaction; nothing when
// it is stored already.
void SqlStore::insert_blob(SqlSession& s, const std::string& sha256,
                           std::string_view bytes) {
  const bool inserted =
      s.execute(make_sql(
          dialect_,
          "INSERT INTO blobs (sha256, size, chunk_bytes, created_us) "
          "VALUES (?, ?, ?, ?) ON CONFLICT (sha256) DO NOTHING",
          {sha256, static_cast<std::int64_t>(bytes.size()),
           static_cast<std::int64_t>(kBlobChunkBytes), now_us()})) == 1;
  if (!inserted) return touch_blobs(s, {sha256});
  std::int64_t index = 0;
  for (size_t at = 0; at < bytes.size(); at += kBlobChunkBytes, ++index) {
    s.execute(make_sql(
        dialect_,
        "INSERT INTO blob_chunks (blob_key, idx, data) VALUES (?, ?, ?)",
        {sha256, index, SqlBytes{bytes.substr(at, kBlobChunkBytes)}}));
  }
}

std::optional<BlobInfo> SqlStore::blob_info(std::string_view sha256) {
  require_valid_hash(sha256);
  std::optional<BlobInfo> info;
  with_read([&](SqlSession& s) {
    auto rows =
        s.query(make_sql(dialect_, "SELECT size FROM blobs WHERE sha256 = ?",
                         {std::string(sha256)}));
    if (!rows.empty()) info = BlobInfo{std::string(sha256), to_int(rows[0][0])};
  });
  return info;
}

void SqlStore::read_blob(std::string_view sha256, std::ostream& out,
                         std::int64_t offset, std::int64_t length) {
  auto info = blob_info(sha256);
  if (!info)
    throw StoreError(ErrorCode::kUnknownBlob,
                     "no blob " + std::string(sha256) + " is stored");
  write_blob_range(
      *info, offset, length,
      [&](std::int64_t index) {
        std::string data;
        with_read([&](SqlSession& s) {
          auto rows = s.query(make_sql(
              dialect_,
              "SELECT data FROM blob_chunks WHERE blob_key = ? AND idx = ?",
              {info->sha256, index}));
          if (!rows.empty() && rows[0][0]) data = std::move(*rows[0][0]);
        });
        return data;
      },
      out);
}

std::size_t SqlStore::collect_garbage(std::chrono::seconds min_age) {
  const std::int64_t cutoff =
      now_us() -
      std::chrono::duration_cast<std::chrono::microseconds>(min_age).count();
  std::size_t removed = 0;
  with_write([&](SqlSession& s) {
    // The write lock orders this against document writes, so a blob is never
    // removed between a writer's existence check and its reference.
    const char* unreferenced =
        "SELECT sha256 FROM blobs WHERE created_us <= ? AND NOT EXISTS "
        "(SELECT 1 FROM blob_refs r WHERE r.sha256 = blobs.sha256)";
    s.execute(
        make_sql(dialect_,
                 std::string("DELETE FROM blob_chunks WHERE blob_key IN (") +
                     unreferenced + ")",
                 {cutoff}));
    removed = static_cast<std::size_t>(s.execute(make_sql(
        dialect_,
        std::string("DELETE FROM blobs WHERE sha256 IN (") + unreferenced + ")",
        {cutoff})));
    s.execute(make_sql(dialect_,
                       "DELETE FROM blob_chunks WHERE blob_key IN (SELECT "
                       "upload_id FROM blob_uploads WHERE started_us <= ?)",
                       {cutoff}));
    s.execute(make_sql(
        dialect_, "DELETE FROM blob_uploads WHERE started_us <= ?", {cutoff}));
  });
  if (removed > 0) spdlog::info("event=blob_gc removed={}", removed);
  return removed;
}

std::vector<Change> SqlStore::changes(std::int64_t since,
                                      std::string_view pattern,
                                      std::size_t limit) {
  validate_pattern(pattern);
  if (since < 0)
    throw StoreError(ErrorCode::kInvalidArgument, "since must be >= 0");
  return collect_changes(
      [&](std::int64_t after, std::size_t page) {
        std::vector<Change> out;
        with_read([&](SqlSession& s) {
          for (const SqlRow& row : s.query(change_page(dialect_, after, page)))
            out.push_back(decode_change(row));
        });
        return out;
      },
      since, pattern, limit);
}

std::int64_t SqlStore::last_seq() {
  std::int64_t seq = 0;
  with_read([&](SqlSession& s) {
    auto rows = s.query(
        make_sql(dialect_, "SELECT value FROM counters WHERE name = 'seq'"));
    if (!rows.empty()) seq = to_int(rows[0][0]);
  });
  return seq;
}

void SqlStore::wait_for_change(std::int64_t after,
                               std::chrono::milliseconds timeout) {
  signal_.wait(after, timeout);
}

StoreStats SqlStore::stats() {
  StoreStats st;
  with_read([&](SqlSession& s) {
    auto rows = s.query(
        make_sql(dialect_,
                 "SELECT (SELECT count(*) FROM documents WHERE deleted = 0), "
                 "(SELECT count(*) FROM blobs), "
                 "(SELECT coalesce(sum(size), 0) FROM blobs), "
                 "(SELECT value FROM counters WHERE name = 'seq')"));
    st.documents = to_int(rows[0][0]);
    st.blobs = to_int(rows[0][1]);
    st.blob_bytes = to_int(rows[0][2]);
    st.last_seq = to_int(rows[0][3]);
  });
  return st;
}

std::vector<int> SqlStore::schema_versions() {
  std::vector<int> out;
  with_read([&](SqlSession& s) {
    for (const SqlRow& r : s.query(make_sql(
             dialect_,
             "SELECT version FROM schema_migrations ORDER BY version")))
      out.push_back(static_cast<int>(to_int(r[0])));
  });
  return out;
}

}  // namespace arscout::db::internal
