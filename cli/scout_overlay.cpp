#include "scout_overlay.h"

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>

#include "arscout/documents/capture.h"
#include "arscout/util/file.h"
#include "cli_support.h"

namespace arscout::cli {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct VerdictWatcher::Pending {
  std::string id;
  std::string file_name;
  Clock::time_point deadline;
  mutable bool said = false;  // registered printed (the poll thread's)
};

namespace {

// One line, written at once: the upload thread prints too.
void say(const std::string& line) { std::cout << line + "\n" << std::flush; }

}  // namespace

VerdictWatcher::VerdictWatcher(http::ClientOptions client, std::string dir,
                               double timeout_s)
    : client_options_(std::move(client)),
      dir_(std::move(dir)),
      timeout_s_(timeout_s) {
  if (!dir_.empty()) fs::create_directories(dir_);
  thread_ = std::thread([this] { run(); });
}

VerdictWatcher::~VerdictWatcher() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void VerdictWatcher::add(const std::string& capture_id,
                         const std::string& file_name) {
  auto p = std::make_shared<Pending>(
      Pending{capture_id, file_name,
              Clock::now() + std::chrono::milliseconds(
                                 static_cast<long long>(timeout_s_ * 1000))});
  {
    std::lock_guard lock(mutex_);
    pending_.push_back(std::move(p));
  }
  changed_.notify_all();
}

int VerdictWatcher::finish() {
  std::unique_lock lock(mutex_);
  while (!pending_.empty() && !stop_requested())
    changed_.wait_for(lock, std::chrono::milliseconds(200));
  return saved_;
}

void VerdictWatcher::run() {
  http::Client client(client_options_);
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    // Poll a copy: add() must not wait for the network.
    const auto round = pending_;
    lock.unlock();
    std::vector<std::shared_ptr<Pending>> done;
    for (const auto& p : round)
      if (poll(client, *p)) done.push_back(p);
    lock.lock();
    for (const auto& p : done) std::erase(pending_, p);
    changed_.notify_all();
    changed_.wait_for(lock, std::chrono::milliseconds(500));
  }
}

bool VerdictWatcher::registered(http::Client& client, const Pending& p,
                                const std::string& site) {
  if (!p.said) {
    const auto model = client.get("/v1/docs/sites/" + site + "/model");
    const std::string version =
        model.status == 200 ? std::to_string(model.json().value("version", 0))
                            : std::string("?");
    say(p.file_name + "  registered · site " + site + " · model v" + version);
    p.said = true;
  }
  if (dir_.empty()) return true;
  const auto overlay = client.get("/v1/captures/" + p.id + "/overlay.jpg");
  if (overlay.status != 200) return false;
  const fs::path out =
      fs::path(dir_) / (fs::path(p.file_name).stem().string() + ".overlay.jpg");
  util::write_file_atomic(out.string(), overlay.body);
  say(p.file_name + "  overlay " + out.string());
  std::lock_guard lock(mutex_);
  ++saved_;
  return true;
}

bool VerdictWatcher::poll(http::Client& client, const Pending& p) {
  const std::string& name = p.file_name;
  const std::string lead = dir_.empty() ? "  " : "  no overlay: ";
  try {
    const auto doc = client.get("/v1/docs/captures/" + p.id);
    const documents::Capture capture = documents::capture_from_json(
        doc.status == 200 ? doc.json().value("attrs", nlohmann::json::object())
                          : nlohmann::json::object());
    using documents::CaptureStatus;
    const std::optional<CaptureStatus> status = capture.status;
    if (status == CaptureStatus::kRejected ||
        status == CaptureStatus::kWithdrawn) {
      say(name + lead + to_string(*status) + " " + capture.status_reason);
      return true;
    }
    if (status == CaptureStatus::kRegistered &&
        registered(client, p, capture.site))
      return true;
  } catch (const std::exception&) {  // network trouble: try again later
  }
  if (Clock::now() < p.deadline) return false;
  say(name + lead + "not registered within " +
      std::to_string(static_cast<int>(timeout_s_)) + " s");
  return true;
}

}  // namespace arscout::cli
