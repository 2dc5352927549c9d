// GPS fixes from a GPX track a scout's separate receiver recorded
// (read_gpx, gps.h), read with expat. The file comes from the scout's
// device, so it is treated as hostile: its size is bounded, a DOCTYPE may
// declare no entities (no billion laughs, no external entities), and
// nothing outside the file is ever loaded.
#include <expat.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#include "arscout/metadata/gps.h"
#include "arscout/util/file.h"
#include "gps_text.h"

namespace arscout::metadata {
namespace {

using gps_text::parse_double;
using gps_text::parse_int;
using gps_text::trim;

// h_acc = DOP times the receiver's user equivalent range error, for which 5 m
// is typical of single-frequency consumer GPS.
constexpr double kUereMetres = 5.0;

// A day at one point a second is about 20 MB of GPX; far more is no track a
// scout carries, and would only cost memory.
constexpr std::uintmax_t kMaxGpxBytes = 256u << 20;

// "trkpt" of "gpx:trkpt": GPX files differ in their namespace prefixes, and
// the reader is not namespace-aware so that an undeclared prefix is no error.
std::string_view local_name(const XML_Char* name) {
  std::string_view n(name);
  if (auto colon = n.rfind(':'); colon != std::string_view::npos)
    n.remove_prefix(colon + 1);
  return n;
}

// The value of attribute `name` in expat's name, value, ..., null list.
const XML_Char* attribute(const XML_Char** attrs, std::string_view name) {
  for (; attrs[0]; attrs += 2)
    if (name == attrs[0]) return attrs[1];
  return nullptr;
}

// A trkpt being read.
struct PendingPoint {
  GpsFix fix;
  std::optional<std::int64_t> time_s;
  int line = 0;
};

double gpx_number(std::string_view text, std::string_view what) {
  auto v = parse_double(text);
  if (!v)
    throw std::runtime_error("<" + std::string(what) + "> '" +
                             std::string(text) + "' is not a number");
  return *v;
}

PendingPoint start_point(const XML_Char** attrs, int line) {
  PendingPoint p;
  p.line = line;
  const XML_Char* lat = attribute(attrs, "lat");
  const XML_Char* lon = attribute(attrs, "lon");
  if (!lat || !lon)
    throw std::runtime_error("<trkpt> needs lat and lon attributes");
  p.fix.lat = gpx_number(lat, "trkpt lat");
  p.fix.lon = gpx_number(lon, "trkpt lon");
  p.fix.source = "gpx";
  return p;
}

void set_field(PendingPoint& p, std::string_view name, std::string_view text) {
  text = trim(text);
  if (name == "ele") {
    p.fix.alt = gpx_number(text, name);
  } else if (name == "time") {
    p.time_s = parse_time_utc(text);
    if (!p.time_s)
      throw std::runtime_error("<time> '" + std::string(text) +
                               "' is not an RFC 3339 time");
    p.fix.time = format_time_utc(*p.time_s);
  } else if (name == "hdop") {
    p.fix.h_acc = gpx_number(text, name) * kUereMetres;
  } else if (name == "vdop") {
    p.fix.v_acc = gpx_number(text, name) * kUereMetres;
  } else if (name == "sat") {
    p.fix.satellites = parse_int(text);
    if (!p.fix.satellites)
      throw std::runtime_error("<sat> '" + std::string(text) +
                               "' is not an integer");
  }
}

// An error that belongs to a line other than the current event's.
struct GpxLineError : std::runtime_error {
  GpxLineError(int line, const std::string& what)
      : std::runtime_error(what), line(line) {}
  int line;
};

// Encodings expat does not know (windows-1252 from older tools) are read
// byte for byte as Latin-1: GPX's markup and numbers are ASCII, and the
// text that would be mis-decoded (names, descriptions) is not read.
int XMLCALL latin1_for_unknown(void*, const XML_Char*, XML_Encoding* info) {
  for (int i = 0; i < 256; ++i) info->map[i] = i;
  info->data = nullptr;
  info->convert = nullptr;
  info->release = nullptr;
  return XML_STATUS_OK;
}

using ParserPtr = std::unique_ptr<XML_ParserStruct, decltype(&XML_ParserFree)>;

// Reads the points; errors name the line of the element, or of the point.
// Exceptions must not unwind through expat's C frames: a handler keeps the
// first error and stops the parser, and read() throws it afterwards.
class GpxReader {
 public:
  explicit GpxReader(std::string_view doc)
      : doc_(doc), parser_(XML_ParserCreate(nullptr), &XML_ParserFree) {
    if (!parser_) throw std::bad_alloc();
    XML_Parser p = parser_.get();
    XML_SetUserData(p, this);
    XML_SetElementHandler(p, on_start, on_end);
    XML_SetCharacterDataHandler(p, on_text);
    XML_SetEntityDeclHandler(p, on_entity_decl);
    XML_SetUnknownEncodingHandler(p, latin1_for_unknown, nullptr);
    // The default already, stated because the external DTD must never load.
    XML_SetParamEntityParsing(p, XML_PARAM_ENTITY_PARSING_NEVER);
  }

  std::vector<TrackPoint> read() {
    const XML_Status status = XML_Parse(
        parser_.get(), doc_.data(), static_cast<int>(doc_.size()), XML_TRUE);
    if (!error_.empty()) throw std::runtime_error(error_);
    if (status != XML_STATUS_OK) parse_error();
    if (point_) throw std::runtime_error("unterminated <trkpt>");
    return std::move(points_);
  }

 private:
  static GpxReader& self(void* user) { return *static_cast<GpxReader*>(user); }

  static void XMLCALL on_start(void* user, const XML_Char* name,
                               const XML_Char** attrs) {
    self(user).guarded([&](GpxReader& r) { r.start(name, attrs); });
  }
  static void XMLCALL on_end(void* user, const XML_Char* name) {
    self(user).guarded([&](GpxReader& r) { r.end(name); });
  }
  static void XMLCALL on_text(void* user, const XML_Char* s, int len) {
    GpxReader& r = self(user);
    if (r.point_ && r.depth_ > 0) r.text_.append(s, static_cast<size_t>(len));
  }
  // Entities are the billion-laughs and external-entity attacks, and GPX
  // needs none beyond the predefined ones; refused before any expansion.
  static void XMLCALL on_entity_decl(void* user, const XML_Char* name, int,
                                     const XML_Char*, int, const XML_Char*,
                                     const XML_Char*, const XML_Char*,
                                     const XML_Char*) {
    self(user).guarded([&](GpxReader&) -> void {
      throw std::runtime_error("the DOCTYPE declares entity '" +
                               std::string(name) +
                               "': a GPX file may declare none");
    });
  }

  template <class F>
  void guarded(F f) {
    if (!error_.empty()) return;
    try {
      f(*this);
    } catch (const GpxLineError& e) {
      stop("line " + std::to_string(e.line) + ": " + e.what());
    } catch (const std::exception& e) {
      stop("line " + std::to_string(line()) + ": " + e.what());
    }
  }

  void stop(std::string message) {
    error_ = std::move(message);
    XML_StopParser(parser_.get(), XML_FALSE);
  }

  int line() const {
    return static_cast<int>(XML_GetCurrentLineNumber(parser_.get()));
  }

  void start(const XML_Char* name, const XML_Char** attrs) {
    open_.emplace_back(name);
    if (!point_) {
      if (local_name(name) == "trkpt") point_ = start_point(attrs, line());
    } else if (depth_++ == 0) {
      // Only the point's own children; extensions may reuse the names.
      field_ = local_name(name);
      text_.clear();
    }
  }

  void end(const XML_Char*) {
    open_.pop_back();
    if (!point_) return;
    if (depth_ == 0) return finish_point();  // expat matched it: </trkpt>
    if (--depth_ == 0) set_field(*point_, field_, text_);
  }

  void finish_point() {
    if (auto error = validate_gps(point_->fix); !error.empty())
      throw GpxLineError(point_->line, error);
    if (point_->time_s) points_.push_back({*point_->time_s, point_->fix});
    point_.reset();
  }

  // Throws the XML error in the words of the checks before expat where
  // they have some. A file that ends inside its elements is a logger that
  // stopped mid-track: its complete points count.
  void parse_error() {
    const XML_Error code = XML_GetErrorCode(parser_.get());
    if (code == XML_ERROR_NO_ELEMENTS) return;
    std::string what;
    if (code == XML_ERROR_TAG_MISMATCH)
      what = "unexpected </" + end_tag_name() + ">" +
             (open_.empty() ? "" : ", expected </" + open_.back() + ">");
    else if (code == XML_ERROR_UNCLOSED_TOKEN)
      what = "unterminated tag";
    else
      what = std::string("not well-formed XML (") + XML_ErrorString(code) + ")";
    throw std::runtime_error("line " + std::to_string(line()) + ": " + what);
  }

  // The name in the end tag at the error (expat points into the tag).
  std::string end_tag_name() const {
    const XML_Index at = XML_GetCurrentByteIndex(parser_.get());
    if (at < 0) return "?";
    const auto open = doc_.rfind("</", static_cast<std::size_t>(at));
    if (open == std::string_view::npos) return "?";
    std::string_view rest = doc_.substr(open + 2);
    return std::string(rest.substr(0, rest.find_first_of(" \t\r\n>")));
  }

  std::string_view doc_;
  ParserPtr parser_;
  std::string error_;  // the first error a handler met
  std::vector<TrackPoint> points_;
  std::vector<std::string> open_;  // the open elements, for error messages
  std::optional<PendingPoint> point_;
  int depth_ = 0;  // element depth inside the current trkpt
  std::string field_;
  std::string text_;
};

// The file's bytes, refused before reading when it is too big to be a track.
std::string read_bounded(const std::string& path) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (!ec && size > kMaxGpxBytes)
    throw std::runtime_error(path + ": " + std::to_string(size) +
                             " bytes, more than a GPX track's " +
                             std::to_string(kMaxGpxBytes));
  std::string doc = util::read_file(path);
  if (doc.size() > kMaxGpxBytes)  // it grew while we looked
    throw std::runtime_error(path + ": more than a GPX track's " +
                             std::to_string(kMaxGpxBytes) + " bytes");
  return doc;
}

}  // namespace

std::vector<TrackPoint> read_gpx(const std::string& path) {
  const std::string doc = read_bounded(path);
  std::vector<TrackPoint> points;
  try {
    points = GpxReader(doc).read();
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  if (points.empty())
    throw std::runtime_error(path + ": no <trkpt> with lat, lon and <time>");
  std::stable_sort(points.begin(), points.end(),
                   [](const TrackPoint& a, const TrackPoint& b) {
                     return a.time_s < b.time_s;
                   });
  return points;
}

}  // namespace arscout::metadata
