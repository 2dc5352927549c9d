// A zip archive built in memory, files stored uncompressed (method 0):
// what Cesium's and GIS tools' users unzip. No zip64: the whole archive
// stays under 4 GiB.
#pragma once

#include <cstdint>
#include <string>

namespace arscout::viewer {

class ZipWriter {
 public:
  // `mtime_s` is seconds since 1970 (UTC), stored as an MS-DOS date.
  // Throws std::invalid_argument for an empty name or one over 65535
  // bytes, and std::length_error past 4 GiB.
  void add(const std::string& name, const std::string& bytes,
           std::int64_t mtime_s);
  // The archive with its central directory.
  std::string finish();

 private:
  std::string out_;
  std::string central_;
  std::uint16_t entries_ = 0;
};

}  // namespace arscout::viewer
