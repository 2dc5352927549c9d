// --watch: new photos uploaded as they appear in the folder.
#include <map>

#include "scout_internal.h"

namespace arscout::scout {
namespace {

namespace fs = std::filesystem;

// A file's size and modification time, to see when a new one is complete.
using FileSignature = std::pair<std::uintmax_t, fs::file_time_type>;

std::optional<FileSignature> signature(const fs::path& path) {
  std::error_code ec1, ec2;
  auto size = fs::file_size(path, ec1);
  auto time = fs::last_write_time(path, ec2);
  if (ec1 || ec2) return std::nullopt;
  return FileSignature{size, time};
}

}  // namespace

void ScoutClient::watch(const std::string& dir) {
  Impl& s = *impl_;
  s.err << "watching " << dir << " for new photos (Ctrl-C to stop)\n";
  std::map<std::string, FileSignature> pending;
  while (s.wait(s.options.watch_poll_s)) {
    for (const auto& path : list_photos(dir, s.err)) {
      std::string name = path.filename().string();
      auto sig = signature(path);
      if (s.done.count(name) || !sig) continue;
      auto it = pending.find(name);
      // Not sent until it looks the same on two polls in a row: a photo
      // still being copied in would go half-written.
      if (it == pending.end() || it->second != *sig) {
        pending[name] = *sig;
        continue;
      }
      if (!pace()) return;
      pending.erase(it);
      s.done.insert(name);
      s.upload(path);
      if (s.stopped() || s.totals.refused) return;
    }
  }
}

}  // namespace arscout::scout
