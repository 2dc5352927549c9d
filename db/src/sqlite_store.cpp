// SQLite backend: one file in WAL mode, one writer connection (writes are
// serialised by SQLite anyway) and a pool of reader connections, which WAL
// lets run beside the writer. Other processes on the same file are found by
// polling the log (Store::subscribe's poll interval).
#include <fcntl.h>
#include <sqlite3.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <mutex>
#include <random>
#include <thread>
#include <unordered_map>

#include <spdlog/spdlog.h>

#include "backends.h"
#include "sql_store.h"

namespace arscout::db::internal {
namespace {

constexpr int kBusyTimeoutMs = 15000;

// SQLite's own busy timeout sleeps up to 100 ms between tries, so a process
// that writes steadily holds the lock at nearly every wake-up of another, and
// the other waits for seconds (two processes' 600 writes each ran one after
// the other). Short pauses with jitter let a waiting writer in within a few
// of the other's transactions; the total wait stays kBusyTimeoutMs.
int retry_while_busy(void* since_arg, int attempt) {
  using Clock = std::chrono::steady_clock;
  auto& since = *static_cast<Clock::time_point*>(since_arg);
  if (attempt == 0) since = Clock::now();
  if (Clock::now() - since > std::chrono::milliseconds(kBusyTimeoutMs))
    return 0;
  thread_local std::minstd_rand jitter(static_cast<unsigned>(
      ::getpid() ^ std::hash<std::thread::id>{}(std::this_thread::get_id())));
  const int ceiling_us = 50 << std::min(attempt, 5);  // 50 us .. 1.6 ms
  std::this_thread::sleep_for(std::chrono::microseconds(
      ceiling_us / 2 + static_cast<int>(jitter() % (ceiling_us / 2 + 1))));
  return 1;
}

// Conditions of the file or the machine that pass or that an operator can
// fix (a lock, a full or read-only disk, a damaged file) are "unavailable"
// (HTTP 503, retry later); anything else is a bug ("internal").
ErrorCode error_code_of(sqlite3* db) {
  switch (sqlite3_extended_errcode(db) & 0xff) {
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
    case SQLITE_CANTOPEN:
    case SQLITE_NOTADB:
    case SQLITE_READONLY:
    case SQLITE_FULL:
    case SQLITE_IOERR:
    case SQLITE_CORRUPT:
      return ErrorCode::kUnavailable;
    default:
      return ErrorCode::kInternal;
  }
}

// Whether the file system holding `path` refuses writes. On recent kernels
// (6.18 here) an ext4 disk that turned read-only after an error
// (errors=remount-ro) keeps its mount flags, so statvfs() does not tell
// and a probe file is tried.
bool on_read_only_file_system(const std::string& path) {
  std::string dir = path.substr(0, path.find_last_of('/') + 1);
  if (dir.empty()) dir = "./";
  struct statvfs fs {};
  if (statvfs(dir.c_str(), &fs) == 0 && (fs.f_flag & ST_RDONLY) != 0)
    return true;
  const std::string probe =
      dir + ".arscout-write-probe-" + std::to_string(::getpid());
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0600);
  if (fd < 0) return errno == EROFS;
  ::close(fd);
  ::unlink(probe.c_str());
  return false;
}

// The error for the connection's last failure. A disk that turns read-only
// under a running server reaches SQLite as a bare "disk I/O error" (and
// sqlite3_system_errno() has lost the errno by then), so the file system
// is asked.
StoreError error_of(sqlite3* db, const std::string& what) {
  std::string message = what + ": " + sqlite3_errmsg(db);
  const ErrorCode code = error_code_of(db);
  const char* file = sqlite3_db_filename(db, "main");
  const int primary = sqlite3_extended_errcode(db) & 0xff;
  if ((primary == SQLITE_IOERR || primary == SQLITE_READONLY) &&
      file != nullptr && *file != '\0' && on_read_only_file_system(file))
    message += " (its file system has turned read-only)";
  return StoreError(code, message);
}

[[noreturn]] void fail(sqlite3* db, const std::string& what) {
  throw error_of(db, what);
}

class Connection : public SqlSession {
 public:
  explicit Connection(const std::string& path) {
    int rc = sqlite3_open_v2(
        path.c_str(), &db_,
        SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX,
        nullptr);
    if (rc != SQLITE_OK) {
      std::string msg = db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
      sqlite3_close(db_);
      throw StoreError(ErrorCode::kUnavailable,
                       "cannot open SQLite database '" + path + "': " + msg +
                           (on_read_only_file_system(path)
                                ? " (it is on a read-only file system)"
                                : ""));
    }
    sqlite3_busy_handler(db_, retry_while_busy, &busy_since_);
    sqlite3_extended_result_codes(db_, 1);
  }
  bool read_only() const { return sqlite3_db_readonly(db_, "main") == 1; }

  ~Connection() override {
    for (auto& [sql, stmt] : cache_) sqlite3_finalize(stmt);
    sqlite3_close(db_);
  }

  std::vector<SqlRow> query(const SqlStatement& st) override {
    sqlite3_stmt* stmt = prepare(st);
    std::vector<SqlRow> rows;
    int rc;
    while ((rc = sqlite3_step(stmt)) == SQLITE_ROW) {
      int n = sqlite3_column_count(stmt);
      SqlRow row(n);
      for (int i = 0; i < n; ++i) {
        if (sqlite3_column_type(stmt, i) == SQLITE_NULL) continue;
        const void* p = sqlite3_column_blob(stmt, i);
        int len = sqlite3_column_bytes(stmt, i);
        row[i] = std::string(static_cast<const char*>(p), len);
      }
      rows.push_back(std::move(row));
    }
    finish(stmt, rc, st.sql);
    return rows;
  }

  std::int64_t execute(const SqlStatement& st) override {
    sqlite3_stmt* stmt = prepare(st);
    int rc = sqlite3_step(stmt);
    finish(stmt, rc, st.sql);
    return sqlite3_changes(db_);
  }

  void execute_script(std::string_view sql) override {
    std::string text(sql);
    if (sqlite3_exec(db_, text.c_str(), nullptr, nullptr, nullptr) != SQLITE_OK)
      fail(db_, "SQLite");
  }

 private:
  sqlite3_stmt* prepare(const SqlStatement& st) {
    sqlite3_stmt*& stmt = cache_[st.sql];
    if (stmt == nullptr &&
        sqlite3_prepare_v3(db_, st.sql.c_str(), -1, SQLITE_PREPARE_PERSISTENT,
                           &stmt, nullptr) != SQLITE_OK) {
      cache_.erase(st.sql);
      fail(db_, "preparing SQL");
    }
    for (std::size_t i = 0; i < st.params.size(); ++i)
      bind(stmt, i + 1, st.params[i]);
    return stmt;
  }

  void bind(sqlite3_stmt* stmt, std::size_t index, const SqlParam& p) {
    int i = static_cast<int>(index), rc = SQLITE_OK;
    if (auto v = std::get_if<std::int64_t>(&p))
      rc = sqlite3_bind_int64(stmt, i, *v);
    else if (auto v = std::get_if<double>(&p))
      rc = sqlite3_bind_double(stmt, i, *v);
    else if (auto v = std::get_if<std::string>(&p))
      rc = sqlite3_bind_text(stmt, i, v->data(), static_cast<int>(v->size()),
                             SQLITE_STATIC);
    else if (auto v = std::get_if<SqlBytes>(&p))
      rc = sqlite3_bind_blob(stmt, i, v->data.data(),
                             static_cast<int>(v->data.size()), SQLITE_STATIC);
    else
      rc = sqlite3_bind_null(stmt, i);
    if (rc != SQLITE_OK) fail(db_, "binding a parameter");
  }

  void finish(sqlite3_stmt* stmt, int rc, const std::string& sql) {
    sqlite3_reset(stmt);
    sqlite3_clear_bindings(stmt);
    if (rc != SQLITE_DONE && rc != SQLITE_ROW)
      fail(db_, "SQLite statement failed (" + sql.substr(0, 60) + ")");
  }

  sqlite3* db_ = nullptr;
  std::chrono::steady_clock::time_point busy_since_;  // of the current wait
  std::unordered_map<std::string, sqlite3_stmt*> cache_;
};

class SqliteStore : public SqlStore {
 public:
  SqliteStore(const std::string& path, const OpenOptions& options)
      : SqlStore(Dialect::kSqlite, options), path_(path) {
    writer_ = std::make_unique<Connection>(path_);
    // SQLite quietly opens a file it may not write read-only; the store
    // must write (the change log, leases), so say so now, not at the first
    // write.
    if (writer_->read_only())
      throw StoreError(ErrorCode::kUnavailable,
                       "SQLite database '" + path_ + "' cannot be written: " +
                           (on_read_only_file_system(path_)
                                ? "it is on a read-only file system"
                                : "no write permission"));
    enable_wal();
    // FULL syncs the WAL at every commit, so an acknowledged write survives
    // a power cut or a disk the kernel turns read-only after an error.
    // NORMAL (sync at checkpoints only) kept the file consistent but lost
    // every upload since the last checkpoint when the disk failed
    // (SqliteDisk.DiskTurningReadOnlyUnderTheServerGives503AndLosesNothing).
    writer_->execute_script("PRAGMA synchronous=FULL");
    if (options.migrate) migrate("sqlite");
    if (schema_versions().empty())
      throw StoreError(ErrorCode::kUnavailable,
                       "SQLite database '" + path_ +
                           "' is not initialised (run 'arscout db init')");
  }

  std::string backend() const override { return "sqlite"; }

  // WAL lets readers run beside the writer. Switching a new file to WAL
  // needs an exclusive lock, and when several processes open the same new
  // file at once SQLite answers SQLITE_BUSY without consulting the busy
  // handler (to avoid a deadlock), so the switch is retried here.
  void enable_wal() {
    auto deadline = std::chrono::steady_clock::now() +
                    std::chrono::milliseconds(kBusyTimeoutMs);
    for (auto pause = std::chrono::milliseconds(1);;
         pause = std::min(pause * 2, std::chrono::milliseconds(100))) {
      try {
        writer_->execute_script("PRAGMA journal_mode=WAL");
        return;
      } catch (const StoreError& e) {
        if (e.code() != ErrorCode::kUnavailable ||
            std::chrono::steady_clock::now() > deadline)
          throw;
        std::this_thread::sleep_for(pause);
      }
    }
  }

 protected:
  void with_read(const SessionFn& fn) override {
    std::unique_ptr<Connection> conn = acquire_reader();
    try {
      fn(*conn);
    } catch (...) {
      release_reader(std::move(conn));
      throw;
    }
    release_reader(std::move(conn));
  }

  void with_write(const SessionFn& fn) override {
    std::lock_guard lock(write_mu_);
    // IMMEDIATE takes the file's write lock now, so our reads inside the
    // transaction see every earlier commit, also from other processes.
    writer_->execute_script("BEGIN IMMEDIATE");
    try {
      fn(*writer_);
      writer_->execute_script("COMMIT");
    } catch (...) {
      try {
        writer_->execute_script("ROLLBACK");
      } catch (const StoreError& e) {
        spdlog::error("event=sqlite_rollback_failed error=\"{}\"", e.what());
      }
      throw;
    }
  }

  void with_migration_lock(const SessionFn& fn) override { with_write(fn); }

 private:
  std::unique_ptr<Connection> acquire_reader() {
    {
      std::lock_guard lock(pool_mu_);
      if (!readers_.empty()) {
        auto conn = std::move(readers_.back());
        readers_.pop_back();
        return conn;
      }
    }
    return std::make_unique<Connection>(path_);
  }

  void release_reader(std::unique_ptr<Connection> conn) {
    std::lock_guard lock(pool_mu_);
    if (readers_.size() < static_cast<std::size_t>(options_.pool_size))
      readers_.push_back(std::move(conn));
  }

  std::string path_;
  std::mutex write_mu_;
  std::unique_ptr<Connection> writer_;
  std::mutex pool_mu_;
  std::vector<std::unique_ptr<Connection>> readers_;
};

}  // namespace

std::unique_ptr<Store> open_sqlite(const std::string& path,
                                   const OpenOptions& options) {
  return std::make_unique<SqliteStore>(path, options);
}

}  // namespace arscout::db::internal
