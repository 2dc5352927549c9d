// PostgreSQL backend (libpqxx): a pool of connections, writers serialised by
// the counters row lock (taken first in every write transaction), and
// LISTEN/NOTIFY for wake-ups on a connection of its own. A lost connection is
// replaced on the next use; subscribers catch up from the log.

// pqxx 6.4's only runtime-built parameter lists (a mix of text, numbers and
// binary) are the prepared-statement invocations it marks deprecated.
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"

#include <atomic>
#include <mutex>
#include <thread>
#include <unordered_set>

#include <spdlog/spdlog.h>
#include <pqxx/pqxx>

#include "arscout/util/sha256.h"
#include "backends.h"
#include "sql_store.h"

namespace arscout::db::internal {
namespace {

constexpr const char* kChannel = "arscout_changes";
constexpr long kMigrationLockKey = 0x61727363;  // "arsc"
constexpr unsigned kByteaOid = 17;

// The URL without its password, for messages and logs.
std::string redact(const std::string& url) {
  auto scheme = url.find("://");
  auto at = url.find('@');
  if (scheme == std::string::npos || at == std::string::npos) return url;
  auto colon = url.find(':', scheme + 3);
  if (colon == std::string::npos || colon > at) return url;
  return url.substr(0, colon) + ":***" + url.substr(at);
}

// Maps a libpqxx failure to the store's error kinds.
[[noreturn]] void rethrow_pqxx(const std::string& context) {
  try {
    throw;
  } catch (const pqxx::in_doubt_error& e) {
    throw StoreError(ErrorCode::kUnavailable,
                     context +
                         ": connection lost during commit; the write "
                         "may or may not have been applied: " +
                         e.what());
  } catch (const pqxx::broken_connection& e) {
    throw StoreError(ErrorCode::kUnavailable,
                     context + ": PostgreSQL connection lost: " + e.what());
  } catch (const pqxx::sql_error& e) {
    std::string state = e.sqlstate();
    bool transient = state.rfind("08", 0) == 0 || state.rfind("57P", 0) == 0 ||
                     state == "53300" || state == "40001" || state == "40P01";
    throw StoreError(transient ? ErrorCode::kUnavailable : ErrorCode::kInternal,
                     context + ": PostgreSQL error " + state + ": " + e.what());
  }
}

class PgSession : public SqlSession {
 public:
  PgSession(pqxx::connection& conn, pqxx::transaction_base& tx,
            std::unordered_set<std::string>& prepared)
      : conn_(conn), tx_(tx), prepared_(prepared) {}

  std::vector<SqlRow> query(const SqlStatement& st) override {
    pqxx::result r = run(st);
    std::vector<SqlRow> rows;
    rows.reserve(r.size());
    for (const auto& row : r) {
      SqlRow out(row.size());
      for (pqxx::row::size_type i = 0; i < row.size(); ++i) {
        if (row[i].is_null()) continue;
        if (row[i].type() == kByteaOid)
          out[i] = pqxx::binarystring(row[i]).str();
        else
          out[i] = std::string(row[i].c_str(), row[i].size());
      }
      rows.push_back(std::move(out));
    }
    return rows;
  }

  std::int64_t execute(const SqlStatement& st) override {
    return static_cast<std::int64_t>(run(st).affected_rows());
  }

  void execute_script(std::string_view sql) override {
    tx_.exec(std::string(sql));
  }

 private:
  pqxx::result run(const SqlStatement& st) {
    // Statements are prepared once per connection, named by their text.
    std::string name(1, 's');  // appended: dodges a GCC 12 -Wrestrict bug
    name += std::string_view(util::sha256_hex(st.sql)).substr(0, 24);
    if (prepared_.insert(name).second) conn_.prepare(name, st.sql);
    auto call = tx_.prepared(name);
    std::vector<pqxx::binarystring> keep;  // binary params must outlive exec
    keep.reserve(st.params.size());
    for (const SqlParam& p : st.params) {
      if (auto v = std::get_if<std::int64_t>(&p))
        call(*v);
      else if (auto v = std::get_if<double>(&p))
        call(*v);
      else if (auto v = std::get_if<std::string>(&p))
        call(*v);
      else if (auto v = std::get_if<SqlBytes>(&p)) {
        keep.emplace_back(v->data.data(), v->data.size());
        call(keep.back());
      } else
        call();
    }
    return call.exec();
  }

  pqxx::connection& conn_;
  pqxx::transaction_base& tx_;
  std::unordered_set<std::string>& prepared_;
};

struct PooledConnection {
  std::unique_ptr<pqxx::connection> conn;
  std::unordered_set<std::string> prepared;
};

class PostgresStore : public SqlStore {
 public:
  PostgresStore(const std::string& url, const OpenOptions& options)
      : SqlStore(Dialect::kPostgres, options), url_(url) {
    release(acquire());  // fail fast with a clear message
    if (options.migrate) migrate("postgresql");
    if (schema_versions().empty())
      throw StoreError(ErrorCode::kUnavailable,
                       "PostgreSQL database " + redact(url_) +
                           " is not initialised (run 'arscout db init')");
  }

  ~PostgresStore() override {
    stop_listener_ = true;
    if (listener_.joinable()) listener_.join();
  }

  std::string backend() const override { return "postgresql"; }

  void wait_for_change(std::int64_t after,
                       std::chrono::milliseconds timeout) override {
    std::call_once(listener_started_,
                   [this] { listener_ = std::thread([this] { listen(); }); });
    SqlStore::wait_for_change(after, timeout);
  }

 protected:
  void with_read(const SessionFn& fn) override {
    // A read is safe to repeat, so one lost connection is retried at once.
    for (int attempt = 0;; ++attempt) {
      try {
        run<pqxx::nontransaction>(fn, "read");
        return;
      } catch (const StoreError& e) {
        if (e.code() != ErrorCode::kUnavailable || attempt > 0) throw;
      }
    }
  }

  void with_write(const SessionFn& fn) override {
    run<pqxx::work>(fn, "write");
  }

  void with_migration_lock(const SessionFn& fn) override {
    run<pqxx::work>(
        [&](SqlSession& s) {
          s.execute_script("SELECT pg_advisory_xact_lock(" +
                           std::to_string(kMigrationLockKey) + ")");
          fn(s);
        },
        "migrate");
  }

 private:
  // Opens a transaction of type Tx on a pooled connection. A pooled
  // connection that died while idle fails at BEGIN, before anything of ours
  // was sent, so it is dropped and the next one tried.
  template <typename Tx>
  std::unique_ptr<Tx> begin(PooledConnection& pc) {
    for (int attempt = 0;; ++attempt) {
      pc = acquire();
      try {
        return std::make_unique<Tx>(*pc.conn);
      } catch (const pqxx::broken_connection&) {
        if (attempt >= options_.pool_size) rethrow_pqxx("PostgreSQL begin");
      }
    }
  }

  template <typename Tx>
  void run(const SessionFn& fn, const char* what) {
    PooledConnection pc;
    std::unique_ptr<Tx> txp = begin<Tx>(pc);
    try {
      Tx& tx = *txp;
      PgSession session(*pc.conn, tx, pc.prepared);
      fn(session);
      tx.commit();
    } catch (const StoreError&) {
      txp.reset();  // rolls back
      release(std::move(pc));
      throw;
    } catch (const pqxx::failure&) {
      txp.reset();
      release(std::move(pc));  // dropped there unless still open
      rethrow_pqxx(std::string("PostgreSQL ") + what);
    } catch (...) {
      txp.reset();
      release(std::move(pc));
      throw;
    }
    txp.reset();
    release(std::move(pc));
  }

  PooledConnection acquire() {
    {
      std::lock_guard lock(pool_mu_);
      while (!idle_.empty()) {
        PooledConnection pc = std::move(idle_.back());
        idle_.pop_back();
        if (pc.conn->is_open()) return pc;
      }
    }
    return PooledConnection{connect(), {}};
  }

  void release(PooledConnection pc) {
    std::lock_guard lock(pool_mu_);
    if (pc.conn && pc.conn->is_open() &&
        idle_.size() < static_cast<std::size_t>(options_.pool_size))
      idle_.push_back(std::move(pc));
  }

  std::unique_ptr<pqxx::connection> connect() {
    try {
      return std::make_unique<pqxx::connection>(url_);
    } catch (const std::exception& e) {
      throw StoreError(
          ErrorCode::kUnavailable,
          "cannot connect to PostgreSQL at " + redact(url_) + ": " + e.what());
    }
  }

  class Receiver : public pqxx::notification_receiver {
   public:
    Receiver(pqxx::connection& c, ChangeSignal& signal)
        : pqxx::notification_receiver(c, kChannel), signal_(signal) {}
    void operator()(const std::string& payload, int) override {
      try {
        signal_.publish(std::stoll(payload));
      } catch (const std::exception&) {
      }
    }

   private:
    ChangeSignal& signal_;
  };

  // LISTENs on a connection of its own; reconnects with backoff. Waiters
  // poll as well, so a gap while reconnecting only delays wake-ups.
  void listen() {
    auto backoff = std::chrono::milliseconds(100);
    while (!stop_listener_) {
      try {
        auto conn = connect();
        Receiver receiver(*conn, signal_);
        backoff = std::chrono::milliseconds(100);
        while (!stop_listener_) conn->await_notification(0, 200000);
      } catch (const std::exception& e) {
        if (stop_listener_) break;
        spdlog::warn("event=pg_listen_retry error=\"{}\"", e.what());
        std::this_thread::sleep_for(backoff);
        backoff = std::min(backoff * 2, std::chrono::milliseconds(5000));
      }
    }
  }

  std::string url_;
  std::mutex pool_mu_;
  std::vector<PooledConnection> idle_;
  std::once_flag listener_started_;
  std::thread listener_;
  std::atomic<bool> stop_listener_{false};
};

}  // namespace

std::unique_ptr<Store> open_postgres(const std::string& url,
                                     const OpenOptions& options) {
  return std::make_unique<PostgresStore>(url, options);
}

}  // namespace arscout::db::internal
