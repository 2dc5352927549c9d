// Store implemented once over SQL; a backend supplies sessions, locking and
// change wake-ups (see SqliteStore and PostgresStore).
#pragma once

#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <string>

#include "arscout/db/store.h"
#include "change_signal.h"
#include "sql_query.h"
#include "sql_session.h"

namespace arscout::db::internal {

class SqlStore : public Store {
 public:
  std::vector<Document> query(const Query& query) override;
  std::string explain(const Query& query) override;
  std::optional<Document> get(std::string_view path) override;
  std::vector<Document> get_subtree(std::string_view path,
                                    int max_depth) override;
  std::vector<Document> list_children(std::string_view path) override;
  std::vector<WriteResult> batch(const std::vector<WriteOp>& ops) override;

  std::string put_blob(std::istream& in) override;
  using Store::put_blob;
  std::vector<std::string> put_blobs(
      const std::vector<std::string_view>& blobs) override;
  std::optional<BlobInfo> blob_info(std::string_view sha256) override;
  void read_blob(std::string_view sha256, std::ostream& out,
                 std::int64_t offset, std::int64_t length) override;
  std::size_t collect_garbage(std::chrono::seconds min_age) override;

  std::vector<Change> changes(std::int64_t since, std::string_view pattern,
                              std::size_t limit) override;
  std::int64_t last_seq() override;
  void wait_for_change(std::int64_t after,
                       std::chrono::milliseconds timeout) override;
  std::vector<std::string> claim_leases(const std::vector<std::string>& names,
                                        const std::string& holder,
                                        std::chrono::milliseconds ttl,
                                        std::size_t max_new) override;
  std::vector<std::string> renew_leases(const std::string& holder,
                                        std::chrono::milliseconds ttl) override;
  void release_leases(const std::string& holder,
                      const std::vector<std::string>& names) override;
  std::vector<Lease> leases(std::string_view prefix) override;
  StoreStats stats() override;
  std::vector<int> schema_versions() override;

 protected:
  SqlStore(Dialect dialect, OpenOptions options);

  using SessionFn = std::function<void(SqlSession&)>;
  // Runs fn on a session outside any explicit transaction.
  virtual void with_read(const SessionFn& fn) = 0;
  // Runs fn in a transaction holding the store's write lock, and commits; on
  // an exception rolls back and rethrows. Transient failures (lost
  // connection, busy database) become StoreError(kUnavailable).
  virtual void with_write(const SessionFn& fn) = 0;
  // Runs fn in a transaction that excludes other migrators (the tables may
  // not exist yet, so the write lock is not available).
  virtual void with_migration_lock(const SessionFn& fn) = 0;
  // Called after a commit that appended changes up to seq.
  virtual void committed(std::int64_t seq) { signal_.publish(seq); }

  // Creates or upgrades the schema; called by the backend's constructor.
  void migrate(const std::string& backend_name);

  Dialect dialect_;
  OpenOptions options_;
  ChangeSignal signal_;

 private:
  void touch_blobs(SqlSession& s, const std::vector<std::string>& shas);
  void insert_blob(SqlSession& s, const std::string& sha256,
                   std::string_view bytes);
  // One caller's batch waiting for, or taking part in, a group commit.
  struct PendingBatch {
    const std::vector<WriteOp>* ops;
    std::vector<WriteResult> results;
    std::exception_ptr error;
    bool done = false;
  };
  // Commits the batches in one transaction: one lock, one WAL flush. Each
  // batch still succeeds or fails on its own (a savepoint fences a multi-op
  // batch). If the transaction fails as a whole, each batch is retried in a
  // transaction of its own, so no caller gets another caller's error.
  void commit_group(const std::vector<PendingBatch*>& group);
  // Applies the batches in one write transaction; returns the last seq.
  std::int64_t apply_group(const std::vector<PendingBatch*>& group);

  std::vector<Document> read_documents(const SqlStatement& statement);
  void stage_chunk(const std::string& upload_id, std::int64_t index,
                   std::string_view bytes);

  std::mutex group_mu_;
  std::condition_variable group_cv_;
  std::deque<PendingBatch*> queue_;
  bool committing_ = false;
};

}  // namespace arscout::db::internal
