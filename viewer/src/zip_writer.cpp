#include "zip_writer.h"

#include <zlib.h>

#include <chrono>
#include <limits>
#include <stdexcept>

#include "arscout/util/bytes.h"

namespace arscout::viewer {
namespace {

constexpr std::uint32_t kLocalHeader = 0x04034b50;
constexpr std::uint32_t kCentralHeader = 0x02014b50;
constexpr std::uint32_t kEndOfCentral = 0x06054b50;
constexpr std::uint16_t kVersion = 20;  // 2.0: stored files

struct DosTime {
  std::uint16_t time = 0, date = 0;
};

// MS-DOS time: two-second steps, years from 1980.
DosTime dos_time(std::int64_t mtime_s) {
  using namespace std::chrono;
  const sys_seconds t{seconds(std::max<std::int64_t>(mtime_s, 315532800))};
  const sys_days day = floor<days>(t);
  const year_month_day date(day);
  const hh_mm_ss clock(t - day);
  DosTime dos;
  dos.time = static_cast<std::uint16_t>(clock.hours().count() << 11 |
                                        clock.minutes().count() << 5 |
                                        clock.seconds().count() / 2);
  dos.date =
      static_cast<std::uint16_t>((static_cast<int>(date.year()) - 1980) << 9 |
                                 static_cast<unsigned>(date.month()) << 5 |
                                 static_cast<unsigned>(date.day()));
  return dos;
}

std::uint32_t checked_32(std::size_t n) {
  if (n > std::numeric_limits<std::uint32_t>::max())
    throw std::length_error("zip: past 4 GiB (no zip64)");
  return static_cast<std::uint32_t>(n);
}

// The fields the local and central headers share, from "version needed".
void put_common(util::ByteWriter& w, const DosTime& dos, std::uint32_t crc,
                std::uint32_t size, std::uint16_t name_size) {
  w.put<std::uint16_t>(kVersion);
  w.put<std::uint16_t>(0);  // flags
  w.put<std::uint16_t>(0);  // stored
  w.put<std::uint16_t>(dos.time);
  w.put<std::uint16_t>(dos.date);
  w.put<std::uint32_t>(crc);
  w.put<std::uint32_t>(size);  // compressed
  w.put<std::uint32_t>(size);
  w.put<std::uint16_t>(name_size);
  w.put<std::uint16_t>(0);  // extra field
}

}  // namespace

void ZipWriter::add(const std::string& name, const std::string& bytes,
                    std::int64_t mtime_s) {
  if (name.empty() || name.size() > 0xffff)
    throw std::invalid_argument("zip: a name must be 1 to 65535 bytes");
  if (entries_ == 0xffff)
    throw std::length_error("zip: more than 65535 files (no zip64)");
  const DosTime dos = dos_time(mtime_s);
  const std::uint32_t size = checked_32(bytes.size());
  const auto crc = static_cast<std::uint32_t>(
      crc32_z(0, reinterpret_cast<const Bytef*>(bytes.data()), bytes.size()));
  const auto name_size = static_cast<std::uint16_t>(name.size());
  const std::uint32_t offset = checked_32(out_.size());
  util::ByteWriter local;
  local.put<std::uint32_t>(kLocalHeader);
  put_common(local, dos, crc, size, name_size);
  local.append(name);
  out_ += local.take();
  out_ += bytes;
  checked_32(out_.size());
  util::ByteWriter central;
  central.put<std::uint32_t>(kCentralHeader);
  central.put<std::uint16_t>(kVersion);  // made by
  put_common(central, dos, crc, size, name_size);
  central.put<std::uint16_t>(0);  // comment
  central.put<std::uint16_t>(0);  // disk
  central.put<std::uint16_t>(0);  // internal attributes
  central.put<std::uint32_t>(0);  // external attributes
  central.put<std::uint32_t>(offset);
  central.append(name);
  central_ += central.take();
  ++entries_;
}

std::string ZipWriter::finish() {
  const std::uint32_t start = checked_32(out_.size());
  util::ByteWriter end;
  end.put<std::uint32_t>(kEndOfCentral);
  end.put<std::uint16_t>(0);  // this disk
  end.put<std::uint16_t>(0);  // the directory's disk
  end.put<std::uint16_t>(entries_);
  end.put<std::uint16_t>(entries_);
  end.put<std::uint32_t>(checked_32(central_.size()));
  end.put<std::uint32_t>(start);
  end.put<std::uint16_t>(0);  // comment
  std::string archive = std::move(out_);
  archive += central_;
  archive += end.take();
  checked_32(archive.size());
  out_.clear();
  central_.clear();
  entries_ = 0;
  return archive;
}

}  // namespace arscout::viewer
