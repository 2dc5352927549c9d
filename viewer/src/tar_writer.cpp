#include "tar_writer.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace arscout::viewer {
namespace {

constexpr size_t kBlock = 512;

// `value` in octal, zero-padded to width - 1 digits and NUL-terminated.
void put_octal(char* field, size_t width, unsigned long long value) {
  std::snprintf(field, width, "%0*llo", static_cast<int>(width - 1), value);
}

void pad_to_block(std::string& out) {
  out.append((kBlock - out.size() % kBlock) % kBlock, '\0');
}

}  // namespace

void TarWriter::add(const std::string& name, const std::string& bytes,
                    long long mtime_s) {
  if (name.empty() || name.size() > 100)
    throw std::invalid_argument("tar: bad entry name '" + name + "'");
  char header[kBlock] = {};
  // Fixed-width fields, NUL-padded by the zeroed header, not terminated.
  std::copy_n(name.data(), name.size(), header);
  put_octal(header + 100, 8, 0644);           // mode
  put_octal(header + 108, 8, 0);              // uid
  put_octal(header + 116, 8, 0);              // gid
  put_octal(header + 124, 12, bytes.size());  // size
  put_octal(header + 136, 12, static_cast<unsigned long long>(mtime_s));
  header[156] = '0';                        // regular file
  std::copy_n("ustar", 6, header + 257);    // magic, NUL
  std::copy_n("00", 2, header + 263);       // version
  std::copy_n("arscout", 7, header + 265);  // uname
  std::copy_n("arscout", 7, header + 297);  // gname
  // The checksum is taken with its own field read as eight spaces.
  std::memset(header + 148, ' ', 8);
  unsigned sum = 0;
  for (unsigned char c : header) sum += c;
  std::snprintf(header + 148, 8, "%06o", sum);
  header[155] = ' ';
  out_.append(header, kBlock);
  out_ += bytes;
  pad_to_block(out_);
}

std::string TarWriter::finish() {
  out_.append(2 * kBlock, '\0');
  return std::move(out_);
}

}  // namespace arscout::viewer
