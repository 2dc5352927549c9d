#include "arscout/util/file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace arscout::util {
namespace {

[[noreturn]] void fail(const std::string& path, const char* verb, int error) {
  throw std::runtime_error(path + ": cannot " + verb + " (" +
                           std::strerror(error) + ")");
}

// Opens a new file beside `path` under a name no other writer, thread or
// process, is using.
int open_temp_beside(const std::string& path, std::string& temp) {
  static std::atomic<unsigned> counter{0};
  for (int attempt = 0; attempt < 100; ++attempt) {
    temp = path + ".tmp." + std::to_string(::getpid()) + "." +
           std::to_string(counter++);
    const int fd =
        ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    // EEXIST: a file left by a crashed process that had our pid.
    if (fd >= 0 || errno != EEXIST) return fd;
  }
  return -1;
}

// 0 on success, else an errno value.
int write_all_and_sync(int fd, std::string_view data) {
  for (size_t done = 0; done < data.size();) {
    const ssize_t n = ::write(fd, data.data() + done, data.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return n < 0 ? errno : EIO;
    done += static_cast<size_t>(n);
  }
  // Synced before the rename: otherwise a crash can leave an empty file
  // under the final name on some file systems.
  return ::fsync(fd) == 0 ? 0 : errno;
}

// Best effort: some file systems refuse to sync a folder, and the file
// itself is already safe.
void sync_folder_of(const std::string& path) {
  std::filesystem::path folder = std::filesystem::path(path).parent_path();
  if (folder.empty()) folder = std::filesystem::path(".");
  const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

}  // namespace

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "read", errno ? errno : ENOENT);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (in.bad()) fail(path, "read", EIO);
  return std::move(bytes).str();
}

void write_file_atomic(const std::string& path, std::string_view bytes,
                       std::optional<unsigned> exact_mode) {
  std::string temp;
  const int fd = open_temp_beside(path, temp);
  if (fd < 0) fail(path, "write", errno);
  int error = 0;
  if (exact_mode && ::fchmod(fd, static_cast<mode_t>(*exact_mode)) != 0)
    error = errno;
  if (error == 0) error = write_all_and_sync(fd, bytes);
  if (::close(fd) != 0 && error == 0) error = errno;
  if (error == 0 && ::rename(temp.c_str(), path.c_str()) != 0) error = errno;
  if (error != 0) {
    ::unlink(temp.c_str());
    fail(path, "write", error);
  }
  sync_folder_of(path);
}

}  // namespace arscout::util
