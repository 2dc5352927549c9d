// An uncompressed POSIX ustar archive built in memory: regular files only,
// names up to 100 bytes. Enough for an export that is a handful of text
// files; `tar -xf` and Python's tarfile read it.
#pragma once

#include <string>

namespace arscout::viewer {

class TarWriter {
 public:
  // Throws std::invalid_argument for an empty name or one over 100 bytes.
  void add(const std::string& name, const std::string& bytes,
           long long mtime_s);
  // The archive with its two closing zero blocks.
  std::string finish();

 private:
  std::string out_;
};

}  // namespace arscout::viewer
