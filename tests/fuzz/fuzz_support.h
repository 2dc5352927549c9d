// Shared by the fuzz targets: how a broken property is reported, and the
// scratch file handed to readers that take a path.
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <string_view>

namespace arscout::fuzz {

// A broken property is a finding like a crash: abort() makes libFuzzer save
// the input, and the message says which property it was.
[[noreturn]] inline void fail(const char* what) {
  std::fprintf(stderr, "arscout fuzz property broken: %s\n", what);
  std::abort();
}

inline void check(bool ok, const char* what) {
  if (!ok) fail(what);
}

inline std::string_view as_text(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

// A file of this process in the temporary directory, rewritten for each
// input: the GPS readers are only reachable through a path.
class ScratchFile {
 public:
  explicit ScratchFile(const std::string& suffix)
      : path_((std::filesystem::temp_directory_path() /
               ("arscout-fuzz-" + std::to_string(::getpid()) + suffix))
                  .string()) {}
  ~ScratchFile() { std::remove(path_.c_str()); }
  ScratchFile(const ScratchFile&) = delete;
  ScratchFile& operator=(const ScratchFile&) = delete;

  const std::string& write(std::string_view bytes) {
    // Overwritten and cut to size rather than opened with O_TRUNC: ext4
    // flushes a file truncated to zero when it is closed (auto_da_alloc),
    // which would cost a disk write per input.
    const int fd = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0600);
    if (fd < 0) fail("cannot create the scratch file");
    std::size_t done = 0;
    while (done < bytes.size()) {
      const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
      if (n <= 0) fail("cannot write the scratch file");
      done += static_cast<std::size_t>(n);
    }
    if (::ftruncate(fd, static_cast<off_t>(bytes.size())) != 0 ||
        ::close(fd) != 0)
      fail("cannot write the scratch file");
    return path_;
  }

 private:
  std::string path_;
};

}  // namespace arscout::fuzz
