#include "arscout/util/bytes.h"

#include <stdexcept>
#include <utility>

namespace arscout::util {

std::string ByteWriter::take() {
  std::string out;
  out.swap(out_);
  return out;
}

void ByteWriter::throw_out_of_range(size_t offset, size_t size) const {
  throw std::out_of_range("ByteWriter::put_at: bytes " +
                          std::to_string(offset) + " to " +
                          std::to_string(offset + size) + " of " +
                          std::to_string(out_.size()) + " written");
}

ByteReader::ByteReader(std::string_view in, std::string failure_prefix)
    : in_(in), prefix_(std::move(failure_prefix)) {}

std::string_view ByteReader::take(size_t n) {
  if (left() < n) fail("truncated");
  const std::string_view out = in_.substr(pos_, n);
  pos_ += n;
  return out;
}

void ByteReader::fail(std::string_view what) const {
  std::string message = prefix_;
  message.append(what);
  throw std::runtime_error(message);
}

}  // namespace arscout::util
