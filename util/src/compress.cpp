#include "arscout/util/compress.h"

#include <zlib.h>

#include <algorithm>
#include <limits>
#include <stdexcept>

namespace arscout::util {
namespace {

// zlib counts in uInt: larger inputs go through in pieces of this size.
constexpr std::size_t kPiece = std::numeric_limits<uInt>::max() / 2;

void check_width(std::string_view bytes, std::size_t width) {
  if (width == 0 || bytes.size() % width != 0)
    throw std::invalid_argument("shuffle: " + std::to_string(bytes.size()) +
                                " bytes are not numbers of " +
                                std::to_string(width) + " bytes");
}

// `bytes` as a rows x cols matrix (row by row), written column by column:
// the shuffle, and with rows and cols swapped its inverse.
std::string transpose(std::string_view bytes, std::size_t rows,
                      std::size_t cols) {
  std::string out(bytes.size(), '\0');
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t c = 0; c < cols; ++c)
      out[c * rows + r] = bytes[r * cols + c];
  return out;
}

}  // namespace

std::string deflate_bytes(std::string_view bytes, int level) {
  z_stream z{};
  if (deflateInit(&z, level) != Z_OK)
    throw std::runtime_error("deflate: zlib could not start");
  std::string out(deflateBound(&z, bytes.size()), '\0');
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  std::size_t offset = 0;
  int status = Z_OK;
  while (status == Z_OK) {
    const std::size_t piece = std::min(kPiece, bytes.size() - offset);
    z.next_in =
        reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data())) + offset;
    z.avail_in = static_cast<uInt>(piece);
    offset += piece;
    status = deflate(&z, offset == bytes.size() ? Z_FINISH : Z_NO_FLUSH);
  }
  const std::size_t written = z.total_out;
  deflateEnd(&z);
  if (status != Z_STREAM_END) throw std::runtime_error("deflate: zlib failed");
  out.resize(written);
  return out;
}

std::string inflate_bytes(std::string_view deflated, std::size_t size) {
  if (deflated.size() > std::numeric_limits<uInt>::max() ||
      size > std::numeric_limits<uInt>::max())
    throw std::runtime_error("inflate: too large a stream");
  z_stream z{};
  if (inflateInit(&z) != Z_OK)
    throw std::runtime_error("inflate: zlib could not start");
  std::string out(size, '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(deflated.data()));
  z.avail_in = static_cast<uInt>(deflated.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  const int status = inflate(&z, Z_FINISH);
  const bool whole =
      status == Z_STREAM_END && z.total_out == size && z.avail_in == 0;
  inflateEnd(&z);
  if (!whole)
    throw std::runtime_error(
        status == Z_STREAM_END ? "inflate: the stream is not of the size given"
        : status == Z_BUF_ERROR || status == Z_OK
            ? "inflate: the stream is truncated or larger than given"
            : "inflate: the stream is damaged");
  return out;
}

std::string shuffle_bytes(std::string_view bytes, std::size_t width) {
  check_width(bytes, width);
  return transpose(bytes, bytes.size() / width, width);
}

std::string unshuffle_bytes(std::string_view bytes, std::size_t width) {
  check_width(bytes, width);
  return transpose(bytes, width, bytes.size() / width);
}

}  // namespace arscout::util
