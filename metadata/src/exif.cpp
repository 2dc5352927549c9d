// EXIF of uploaded photos via exiv2. Phones and cameras write every kind of
// broken metadata, so nothing here throws: a tag that is missing, of the
// wrong type or out of range leaves its field empty.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>

#include <exiv2/exiv2.hpp>

#include "arscout/metadata/gps.h"

namespace arscout::metadata {
namespace {

// A consumer receiver's horizontal error is roughly DOP times its user
// equivalent range error; 5 m is typical for single-frequency GPS. Phones
// often write a coarse DOP, so this errs on the pessimistic side, which is
// the safe side for weighting fixes. Only used without GPSHPositioningError.
constexpr double kUereMetres = 5.0;

// exiv2 logs every odd tag to stderr, which would flood a server's log, and
// its XMP toolkit must be initialised once before threads parse images.
void init_exiv2_once() {
  static std::once_flag once;
  std::call_once(once, [] {
    Exiv2::LogMsg::setLevel(Exiv2::LogMsg::mute);
    Exiv2::XmpParser::initialize();
  });
}

const Exiv2::Exifdatum* find(const Exiv2::ExifData& exif, const char* key) {
  auto it = exif.findKey(Exiv2::ExifKey(key));
  if (it == exif.end() || it->count() == 0) return nullptr;
  return &*it;
}

// Component i of a rational (or integer) tag as a double, if it is finite.
std::optional<double> rational(const Exiv2::Exifdatum& d, long i = 0) {
  if (i >= static_cast<long>(d.count())) return std::nullopt;
  Exiv2::Rational r = d.toRational(i);
  if (r.second == 0) return std::nullopt;
  double v = static_cast<double>(r.first) / r.second;
  if (!std::isfinite(v)) return std::nullopt;
  return v;
}

std::optional<double> number(const Exiv2::ExifData& exif, const char* key) {
  const auto* d = find(exif, key);
  return d ? rational(*d) : std::nullopt;
}

std::optional<double> positive(const Exiv2::ExifData& exif, const char* key) {
  auto v = number(exif, key);
  if (v && *v > 0) return v;
  return std::nullopt;
}

// ASCII tags are NUL-padded and often space-padded too.
std::string text(const Exiv2::ExifData& exif, const char* key) {
  const auto* d = find(exif, key);
  if (!d) return "";
  std::string s = d->toString();
  auto end = s.find('\0');
  if (end != std::string::npos) s.resize(end);
  auto first = s.find_first_not_of(" \t");
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(" \t") - first + 1);
}

// Degrees, minutes, seconds (some writers give only one or two parts, with
// the fraction in the last) signed by the N/S or E/W reference.
std::optional<double> coordinate(const Exiv2::ExifData& exif,
                                 const char* value_key, const char* ref_key,
                                 char negative_ref) {
  const auto* d = find(exif, value_key);
  if (!d) return std::nullopt;
  double deg = 0;
  double scale = 1;
  for (long i = 0; i < std::min<long>(3, d->count()); ++i, scale *= 60) {
    auto part = rational(*d, i);
    if (!part || *part < 0) return std::nullopt;
    deg += *part / scale;
  }
  std::string ref = text(exif, ref_key);
  if (!ref.empty() && (ref[0] == negative_ref || ref[0] == negative_ref + 32))
    deg = -deg;
  return deg;
}

// "08" or a list of satellite numbers such as "3 6 12 15": how many.
std::optional<int> satellites(const std::string& s) {
  int count = 0;
  int value = 0;
  bool in_number = false;
  for (char c : s) {
    if (c >= '0' && c <= '9') {
      if (!in_number) ++count;
      in_number = true;
      value = std::min(value * 10 + (c - '0'), 1000);
    } else if (c == ' ' || c == ',' || c == ';') {
      in_number = false;
    } else {
      return std::nullopt;
    }
  }
  if (count == 0) return std::nullopt;
  return count == 1 ? value : count;
}

// GPSDateStamp "YYYY:MM:DD" plus GPSTimeStamp (h, m, s rationals), UTC.
std::string gps_time(const Exiv2::ExifData& exif) {
  std::string date = text(exif, "Exif.GPSInfo.GPSDateStamp");
  const auto* t = find(exif, "Exif.GPSInfo.GPSTimeStamp");
  int y, mo, d;
  if (!t || t->count() < 3 ||
      std::sscanf(date.c_str(), "%4d:%2d:%2d", &y, &mo, &d) != 3)
    return "";
  auto h = rational(*t, 0), mi = rational(*t, 1), s = rational(*t, 2);
  if (!h || !mi || !s || *h < 0 || *h >= 24 || *mi < 0 || *mi >= 60 || *s < 0 ||
      *s >= 61 || mo < 1 || mo > 12 || d < 1 || d > 31)
    return "";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02dZ", y, mo, d,
                static_cast<int>(*h), static_cast<int>(*mi),
                static_cast<int>(*s));
  // The checks above let a 31st of February or a negative year through.
  if (!parse_time_utc(buf)) return "";
  return buf;
}

// Receivers without a fix write GPSStatus "V" (void) or zeros for both
// coordinates; neither is a position.
bool has_fix(const Exiv2::ExifData& exif, double lat, double lon) {
  std::string status = text(exif, "Exif.GPSInfo.GPSStatus");
  if (status == "V") return false;
  return lat != 0 || lon != 0;
}

std::optional<double> horizontal_accuracy(const Exiv2::ExifData& exif) {
  if (auto err = number(exif, "Exif.GPSInfo.GPSHPositioningError");
      err && *err >= 0)
    return err;
  if (auto dop = positive(exif, "Exif.GPSInfo.GPSDOP"))
    return *dop * kUereMetres;
  return std::nullopt;
}

std::optional<GpsFix> read_gps(const Exiv2::ExifData& exif) {
  auto lat = coordinate(exif, "Exif.GPSInfo.GPSLatitude",
                        "Exif.GPSInfo.GPSLatitudeRef", 'S');
  auto lon = coordinate(exif, "Exif.GPSInfo.GPSLongitude",
                        "Exif.GPSInfo.GPSLongitudeRef", 'W');
  if (!lat || !lon || !has_fix(exif, *lat, *lon)) return std::nullopt;
  GpsFix fix;
  fix.lat = *lat;
  fix.lon = *lon;
  fix.source = "exif";
  if (auto alt = number(exif, "Exif.GPSInfo.GPSAltitude"); alt && *alt >= 0) {
    const auto* ref = find(exif, "Exif.GPSInfo.GPSAltitudeRef");
    fix.alt = ref && ref->toLong() == 1 ? -*alt : *alt;  // 1: below sea level
  }
  fix.h_acc = horizontal_accuracy(exif);
  fix.satellites = satellites(text(exif, "Exif.GPSInfo.GPSSatellites"));
  fix.time = gps_time(exif);
  // A fix whose extras are out of range keeps its position.
  if (!validate_gps(fix).empty()) {
    fix.alt.reset();
    fix.satellites.reset();
  }
  if (!validate_gps(fix).empty()) return std::nullopt;
  return fix;
}

// "YYYY:MM:DD HH:MM:SS" -> "YYYY-MM-DDTHH:MM:SS"; blank or zeroed dates
// (cameras whose clock was never set) are no time.
std::string taken_time(const Exiv2::ExifData& exif) {
  std::string s = text(exif, "Exif.Photo.DateTimeOriginal");
  int y, mo, d, h, mi, sec;
  if (std::sscanf(s.c_str(), "%4d:%2d:%2d %2d:%2d:%2d", &y, &mo, &d, &h, &mi,
                  &sec) != 6 ||
      y < 1900 || mo < 1 || mo > 12 || d < 1 || d > 31 || h < 0 || h > 23 ||
      mi < 0 || mi > 59 || sec < 0 || sec > 60)
    return "";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d", y, mo, d, h,
                mi, sec);
  if (!parse_time_utc(buf)) return "";  // a 31st of February, say
  return buf;
}

// FocalPlaneResolutionUnit: 2 inch (the EXIF default), 3 cm; 4 mm and 5 um
// come from TIFF/EP. 1 means no absolute unit, which is useless for sizes.
std::optional<double> focal_plane_unit_mm(const Exiv2::ExifData& exif) {
  const auto* d = find(exif, "Exif.Photo.FocalPlaneResolutionUnit");
  switch (d ? d->toLong() : 2) {
    case 2:
      return 25.4;
    case 3:
      return 10.0;
    case 4:
      return 1.0;
    case 5:
      return 0.001;
    default:
      return std::nullopt;
  }
}

int dimension(const Exiv2::ExifData& exif, const char* key) {
  const auto* d = find(exif, key);
  if (!d) return 0;
  long v = d->toLong();
  return v > 0 && v <= 1000000 ? static_cast<int>(v) : 0;
}

ExifInfo read_info(const Exiv2::ExifData& exif) {
  ExifInfo info;
  info.gps = read_gps(exif);
  info.taken = taken_time(exif);
  info.focal_mm = positive(exif, "Exif.Photo.FocalLength");
  info.focal_35mm = positive(exif, "Exif.Photo.FocalLengthIn35mmFilm");
  info.focal_plane_x_res = positive(exif, "Exif.Photo.FocalPlaneXResolution");
  if (info.focal_plane_x_res)
    info.focal_plane_unit_mm = focal_plane_unit_mm(exif);
  info.make = text(exif, "Exif.Image.Make");
  info.model = text(exif, "Exif.Image.Model");
  info.width = dimension(exif, "Exif.Photo.PixelXDimension");
  info.height = dimension(exif, "Exif.Photo.PixelYDimension");
  return info;
}

// Exiv2 0.27's API hands images out as std::auto_ptr, deprecated since
// C++11; clang says so at every use. Debian 12 has no newer Exiv2.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
ExifInfo read_image(Exiv2::Image::AutoPtr image) {
  if (!image.get()) return {};
  image->readMetadata();
  return read_info(image->exifData());
}

}  // namespace

ExifInfo read_exif(std::string_view image_bytes) {
  init_exiv2_once();
  try {
    return read_image(Exiv2::ImageFactory::open(
        reinterpret_cast<const Exiv2::byte*>(image_bytes.data()),
        static_cast<long>(image_bytes.size())));
  } catch (const std::exception&) {  // Exiv2::Error, or bad_alloc on a bogus
    return {};                       // length field
  }
}

ExifInfo read_exif_file(const std::string& path) {
  init_exiv2_once();
  try {
    // A FileIo, not ImageFactory::open(path): that would fetch "http://..."
    // paths over the network.
    Exiv2::BasicIo::AutoPtr io(new Exiv2::FileIo(path));
    return read_image(Exiv2::ImageFactory::open(std::move(io)));
  } catch (const std::exception&) {
    return {};
  }
}
#pragma GCC diagnostic pop

}  // namespace arscout::metadata
