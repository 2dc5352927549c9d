// Store members that are the same on every backend.
#include "arscout/db/store.h"

#include <atomic>
#include <mutex>
#include <sstream>
#include <streambuf>
#include <thread>

#include <spdlog/spdlog.h>

#include "arscout/db/path.h"
#include "backends.h"
#include "store_core.h"

namespace arscout::db {
namespace {

class ThreadSubscription : public Subscription {
 public:
  ThreadSubscription(Store& store, std::string pattern, std::int64_t since,
                     ChangeCallback callback, std::chrono::milliseconds poll)
      : store_(store),
        pattern_(std::move(pattern)),
        callback_(std::move(callback)),
        poll_(poll),
        last_(since) {
    thread_ = std::thread([this] { run(); });
  }
  ~ThreadSubscription() override { stop(); }

  void stop() override {
    stopping_ = true;
    if (thread_.joinable()) thread_.join();
  }
  std::int64_t last_seq() const override { return last_; }
  std::string error() const override {
    std::lock_guard lock(mu_);
    return error_;
  }

 private:
  static constexpr std::size_t kBatch = 500;

  void run() {
    std::int64_t scanned = last_;  // log position known to hold no more
    auto backoff = std::chrono::milliseconds(50);
    while (!stopping_) {
      try {
        std::int64_t head = store_.last_seq();
        std::vector<Change> batch = store_.changes(last_, pattern_, kBatch);
        if (!deliver(batch)) return;
        if (batch.size() == kBatch) continue;
        scanned = std::max(head, last_.load());
        backoff = std::chrono::milliseconds(50);
        store_.wait_for_change(scanned, poll_);
      } catch (const std::exception& e) {
        // The log is the truth: after a lost connection, retry from last_.
        spdlog::warn(
            "event=subscription_retry pattern={} since={} error=\"{}\"",
            pattern_, last_.load(), e.what());
        std::this_thread::sleep_for(backoff);
        backoff = std::min(backoff * 2, std::chrono::milliseconds(2000));
      }
    }
  }

  // Hands each change to the callback; false once the callback threw.
  bool deliver(const std::vector<Change>& batch) {
    for (const Change& c : batch) {
      if (stopping_) return true;
      try {
        callback_(c);
      } catch (const std::exception& e) {
        std::lock_guard lock(mu_);
        error_ = std::string("callback failed at seq ") +
                 std::to_string(c.seq) + ": " + e.what();
        return false;
      }
      last_ = c.seq;
    }
    return true;
  }

  Store& store_;
  std::string pattern_;
  ChangeCallback callback_;
  std::chrono::milliseconds poll_;
  std::atomic<std::int64_t> last_;
  std::atomic<bool> stopping_{false};
  mutable std::mutex mu_;
  std::string error_;
  std::thread thread_;
};

bool starts_with(const std::string& s, std::string_view prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}

}  // namespace

std::unique_ptr<Store> Store::open(const std::string& url,
                                   const OpenOptions& options) {
  if (starts_with(url, "sqlite:")) {
    std::string path = url.substr(7);
    if (starts_with(path, "//")) path = path.substr(2);  // sqlite://path too
    if (path.empty())
      throw StoreError(ErrorCode::kInvalidArgument,
                       "database URL '" + url + "' names no file");
    return internal::open_sqlite(path, options);
  }
  if (starts_with(url, "postgresql://") || starts_with(url, "postgres://"))
    return internal::open_postgres(url, options);
  throw StoreError(
      ErrorCode::kInvalidArgument,
      "database URL '" + url + "' must start with sqlite: or postgresql://");
}

WriteResult Store::write(const WriteOp& op) { return batch({op}).front(); }

WriteResult Store::put(const std::string& path, const std::string& kind,
                       const Json& attrs,
                       std::optional<std::int64_t> expected) {
  return write(WriteOp::put(path, kind, attrs, expected));
}

WriteResult Store::patch(const std::string& path, const Json& merge_patch,
                         std::optional<std::int64_t> expected) {
  return write(WriteOp::patch(path, merge_patch, expected));
}

WriteResult Store::remove(const std::string& path,
                          std::optional<std::int64_t> expected) {
  return write(WriteOp::remove(path, expected));
}

// Bytes in hand are hashed first: a blob stored already is not written
// again (the engine stores its state in parts, most unchanged from one
// increment to the next). Should garbage collection take it before the
// document that refers to it is written, that write fails with
// kUnknownBlob and is retried.
std::string Store::put_blob(std::string_view bytes) {
  return put_blobs({bytes}).front();
}

std::string Store::get_blob(std::string_view sha256) {
  std::ostringstream out;
  read_blob(sha256, out);
  return std::move(out).str();
}

std::unique_ptr<Subscription> Store::subscribe(std::string pattern,
                                               std::int64_t since,
                                               ChangeCallback callback) {
  validate_pattern(pattern);
  if (since < 0)
    throw StoreError(ErrorCode::kInvalidArgument, "since must be >= 0");
  return std::make_unique<ThreadSubscription>(
      *this, std::move(pattern), since, std::move(callback), poll_interval_);
}

WriteResult Store::save_checkpoint(const std::string& name, std::int64_t seq) {
  return put("/checkpoints/" + name, "checkpoint", Json{{"seq", seq}});
}

std::int64_t Store::last_change(std::string_view pattern) {
  std::int64_t last = 0;
  for (auto page = changes(0, pattern); !page.empty();
       page = changes(last, pattern))
    last = page.back().seq;
  return last;
}

std::int64_t Store::load_checkpoint(const std::string& name) {
  auto doc = get("/checkpoints/" + name);
  if (!doc) return 0;
  return doc->attrs.value("seq", std::int64_t{0});
}

}  // namespace arscout::db
