// Reading binary files back in the viewer's tests, by offset, apart from
// the writers' own byte code (x86 and ARM hosts are little-endian, as LAS
// and glTF are).
#pragma once

#include <cstddef>
#include <cstring>
#include <string>

namespace arscout::viewer::testing_bytes {

template <typename T>
T read_at(const std::string& bytes, std::size_t offset) {
  T value;
  std::memcpy(&value, bytes.data() + offset, sizeof value);
  return value;
}

}  // namespace arscout::viewer::testing_bytes
