// GPS fixes from files a scout brings along: a CSV of fixes per image, or a
// GPX track from a separate receiver that is matched to photos by time.
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "arscout/ingest/gps.h"

namespace arscout::ingest {
namespace {

// h_acc = DOP times the receiver's user equivalent range error, for which 5 m
// is typical of single-frequency consumer GPS.
constexpr double kUereMetres = 5.0;

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

std::string_view trim(std::string_view s) {
  auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t\r\n") - first + 1);
}

std::optional<double> parse_double(std::string_view s) {
  s = trim(s);
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  double v = 0;
  auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc() || end != s.data() + s.size() ||
      !std::isfinite(v))
    return std::nullopt;
  return v;
}

std::optional<int> parse_int(std::string_view s) {
  s = trim(s);
  int v = 0;
  auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc() || end != s.data() + s.size())
    return std::nullopt;
  return v;
}

// Exactly `n` digits at s[pos..]; advances pos.
bool digits(std::string_view s, std::size_t& pos, int n, int* out) {
  if (pos + n > s.size()) return false;
  int v = 0;
  for (int i = 0; i < n; ++i) {
    char c = s[pos + i];
    if (c < '0' || c > '9') return false;
    v = v * 10 + (c - '0');
  }
  pos += n;
  *out = v;
  return true;
}

bool expect(std::string_view s, std::size_t& pos, std::string_view chars) {
  if (pos >= s.size() || chars.find(s[pos]) == std::string_view::npos)
    return false;
  ++pos;
  return true;
}

// The "Z", "+hh:mm" or "-hh:mm" at the end, as seconds east of UTC.
std::optional<int> utc_offset(std::string_view s, std::size_t pos) {
  if (pos == s.size()) return 0;
  if (s.substr(pos) == "Z" || s.substr(pos) == "z") return 0;
  int sign = s[pos] == '-' ? -1 : 1;
  int h, m;
  if (!expect(s, pos, "+-") || !digits(s, pos, 2, &h) || !expect(s, pos, ":") ||
      !digits(s, pos, 2, &m) || pos != s.size() || h > 23 || m > 59)
    return std::nullopt;
  return sign * (h * 3600 + m * 60);
}

// ---- CSV ------------------------------------------------------------------

std::vector<std::string_view> split_csv(std::string_view line) {
  std::vector<std::string_view> cells;
  std::size_t start = 0;
  while (true) {
    auto comma = line.find(',', start);
    cells.push_back(trim(line.substr(start, comma - start)));
    if (comma == std::string_view::npos) return cells;
    start = comma + 1;
  }
}

struct CsvColumns {
  int image = -1, lat = -1, lon = -1, alt = -1, h_acc = -1, v_acc = -1,
      satellites = -1, time = -1;
};

CsvColumns header_columns(std::string_view line) {
  CsvColumns c;
  auto cells = split_csv(line);
  for (int i = 0; i < static_cast<int>(cells.size()); ++i) {
    std::string_view name = cells[i];
    if (name == "image") c.image = i;
    if (name == "latitude") c.lat = i;
    if (name == "longitude") c.lon = i;
    if (name == "altitude") c.alt = i;
    if (name == "horizontal_accuracy_m") c.h_acc = i;
    if (name == "vertical_accuracy_m") c.v_acc = i;
    if (name == "satellites") c.satellites = i;
    if (name == "time") c.time = i;
  }
  if (c.image < 0 || c.lat < 0 || c.lon < 0)
    throw std::runtime_error(
        "expected a header with image, latitude and longitude "
        "columns (image,latitude,longitude,altitude,horizontal_accuracy_m,"
        "vertical_accuracy_m)");
  return c;
}

// The cell of an optional column ("" when the column or the value is absent).
std::string_view cell(const std::vector<std::string_view>& cells, int column) {
  if (column < 0 || column >= static_cast<int>(cells.size())) return {};
  return cells[column];
}

void optional_cell(const std::vector<std::string_view>& cells, int column,
                   const char* name, std::optional<double>* out) {
  std::string_view text = cell(cells, column);
  if (text.empty()) return;
  *out = parse_double(text);
  if (!*out)
    throw std::runtime_error(std::string(name) + " '" + std::string(text) +
                             "' is not a number");
}

GpsFix parse_csv_row(const std::vector<std::string_view>& cells,
                     const CsvColumns& c) {
  std::optional<double> lat, lon;
  optional_cell(cells, c.lat, "latitude", &lat);
  optional_cell(cells, c.lon, "longitude", &lon);
  if (!lat || !lon) throw std::runtime_error("latitude and longitude needed");
  GpsFix fix;
  fix.lat = *lat;
  fix.lon = *lon;
  fix.source = "csv";
  optional_cell(cells, c.alt, "altitude", &fix.alt);
  optional_cell(cells, c.h_acc, "horizontal_accuracy_m", &fix.h_acc);
  optional_cell(cells, c.v_acc, "vertical_accuracy_m", &fix.v_acc);
  if (auto sats = cell(cells, c.satellites); !sats.empty()) {
    fix.satellites = parse_int(sats);
    if (!fix.satellites)
      throw std::runtime_error("satellites '" + std::string(sats) +
                               "' is not an integer");
  }
  if (auto time = cell(cells, c.time); !time.empty()) {
    auto t = parse_time_utc(time);
    if (!t)
      throw std::runtime_error("time '" + std::string(time) +
                               "' is not an RFC 3339 time");
    fix.time = format_time_utc(*t);
  }
  if (auto error = validate_gps(fix); !error.empty())
    throw std::runtime_error(error);
  return fix;
}

// ---- GPX ------------------------------------------------------------------

struct Tag {
  std::string_view name;  // local name, without a namespace prefix
  std::string_view attrs;
  bool closing = false;
  bool self_closing = false;
  std::size_t begin = 0;  // offset of '<'
  std::size_t end = 0;    // offset after '>'
};

std::size_t skip_past(std::string_view doc, std::size_t pos,
                      std::string_view terminator) {
  auto at = doc.find(terminator, pos);
  if (at == std::string_view::npos)
    throw std::runtime_error("unterminated markup");
  return at + terminator.size();
}

// The end of a tag's '>' (quoted attribute values may hold '>').
std::size_t tag_end(std::string_view doc, std::size_t pos) {
  char quote = 0;
  for (; pos < doc.size(); ++pos) {
    char c = doc[pos];
    if (quote) {
      if (c == quote) quote = 0;
    } else if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '>') {
      return pos + 1;
    }
  }
  throw std::runtime_error("unterminated tag");
}

// The next element tag at or after pos; comments, processing instructions,
// declarations and CDATA are skipped.
std::optional<Tag> next_tag(std::string_view doc, std::size_t pos) {
  while (true) {
    pos = doc.find('<', pos);
    if (pos == std::string_view::npos) return std::nullopt;
    std::string_view rest = doc.substr(pos);
    if (rest.starts_with("<!--")) {
      pos = skip_past(doc, pos, "-->");
    } else if (rest.starts_with("<![CDATA[")) {
      pos = skip_past(doc, pos, "]]>");
    } else if (rest.starts_with("<?")) {
      pos = skip_past(doc, pos, "?>");
    } else if (rest.starts_with("<!")) {
      pos = tag_end(doc, pos);
    } else {
      break;
    }
  }
  Tag tag;
  tag.begin = pos;
  tag.end = tag_end(doc, pos);
  std::string_view inner = doc.substr(pos + 1, tag.end - pos - 2);
  tag.closing = inner.starts_with('/');
  if (tag.closing) inner.remove_prefix(1);
  tag.self_closing = inner.ends_with('/');
  if (tag.self_closing) inner.remove_suffix(1);
  auto name_end = std::min(inner.find_first_of(" \t\r\n"), inner.size());
  tag.name = inner.substr(0, name_end);
  tag.attrs = inner.substr(name_end);
  if (auto colon = tag.name.rfind(':'); colon != std::string_view::npos)
    tag.name.remove_prefix(colon + 1);
  return tag;
}

// The value of attribute `name` (no entity decoding: GPX numbers need none).
std::optional<std::string_view> attribute(std::string_view attrs,
                                          std::string_view name) {
  std::size_t pos = 0;
  while (true) {
    pos = attrs.find_first_not_of(" \t\r\n", pos);
    if (pos == std::string_view::npos) return std::nullopt;
    auto eq = attrs.find('=', pos);
    if (eq == std::string_view::npos) return std::nullopt;
    std::string_view key = trim(attrs.substr(pos, eq - pos));
    auto open = attrs.find_first_of("\"'", eq);
    if (open == std::string_view::npos) return std::nullopt;
    auto close = attrs.find(attrs[open], open + 1);
    if (close == std::string_view::npos) return std::nullopt;
    if (key == name) return attrs.substr(open + 1, close - open - 1);
    pos = close + 1;
  }
}

// Line numbers for offsets visited in increasing order.
class LineCounter {
 public:
  explicit LineCounter(std::string_view doc) : doc_(doc) {}
  int at(std::size_t offset) {
    line_ += static_cast<int>(
        std::count(doc_.begin() + pos_, doc_.begin() + offset, '\n'));
    pos_ = offset;
    return line_;
  }

 private:
  std::string_view doc_;
  std::size_t pos_ = 0;
  int line_ = 1;
};

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

PendingPoint start_point(const Tag& tag, int line) {
  PendingPoint p;
  p.line = line;
  auto lat = attribute(tag.attrs, "lat");
  auto lon = attribute(tag.attrs, "lon");
  if (!lat || !lon)
    throw std::runtime_error("<trkpt> needs lat and lon attributes");
  p.fix.lat = gpx_number(*lat, "trkpt lat");
  p.fix.lon = gpx_number(*lon, "trkpt lon");
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

// An error that belongs to a line other than the current tag's.
struct GpxLineError : std::runtime_error {
  GpxLineError(int line, const std::string& what)
      : std::runtime_error(what), line(line) {}
  int line;
};

// Reads the points; errors name the line of the tag, or of the point.
class GpxReader {
 public:
  explicit GpxReader(std::string_view doc) : doc_(doc), lines_(doc) {}

  std::vector<TrackPoint> read() {
    std::size_t pos = 0;
    while (auto tag = next(pos)) {
      int line = lines_.at(tag->begin);
      try {
        on_tag(*tag, line);
      } catch (const GpxLineError& e) {
        throw std::runtime_error("line " + std::to_string(e.line) + ": " +
                                 e.what());
      } catch (const std::runtime_error& e) {
        throw std::runtime_error("line " + std::to_string(line) + ": " +
                                 e.what());
      }
      pos = tag->end;
    }
    if (point_) throw std::runtime_error("unterminated <trkpt>");
    return std::move(points_);
  }

 private:
  std::optional<Tag> next(std::size_t pos) {
    try {
      return next_tag(doc_, pos);
    } catch (const std::runtime_error& e) {
      throw std::runtime_error("line " + std::to_string(lines_.at(pos)) + ": " +
                               e.what());
    }
  }

  void on_tag(const Tag& tag, int line) {
    if (!point_) {
      if (tag.name == "trkpt" && !tag.closing) {
        point_ = start_point(tag, line);
        if (tag.self_closing) finish_point();
      }
    } else if (tag.closing && depth_ == 0) {
      if (tag.name != "trkpt")
        throw std::runtime_error("unexpected </" + std::string(tag.name) + ">");
      finish_point();
    } else if (tag.closing) {
      if (--depth_ == 0)
        set_field(*point_, field_,
                  doc_.substr(text_start_, tag.begin - text_start_));
    } else if (!tag.self_closing) {
      // Only the point's own children; extensions may reuse the names.
      if (depth_++ == 0) {
        field_ = tag.name;
        text_start_ = tag.end;
      }
    }
  }

  void finish_point() {
    if (auto error = validate_gps(point_->fix); !error.empty())
      throw GpxLineError(point_->line, error);
    if (point_->time_s) points_.push_back({*point_->time_s, point_->fix});
    point_.reset();
    depth_ = 0;
  }

  std::string_view doc_;
  LineCounter lines_;
  std::vector<TrackPoint> points_;
  std::optional<PendingPoint> point_;
  int depth_ = 0;  // element depth inside the current trkpt
  std::string_view field_;
  std::size_t text_start_ = 0;
};

// ---- interpolation ----------------------------------------------------------

std::optional<double> lerp(const std::optional<double>& a,
                           const std::optional<double>& b, double w) {
  if (!a || !b) return std::nullopt;
  return *a + (*b - *a) * w;
}

GpsFix interpolate(const GpsFix& a, const GpsFix& b, double w) {
  GpsFix fix;
  fix.lat = a.lat + (b.lat - a.lat) * w;
  double dlon = b.lon - a.lon;
  if (dlon > 180) dlon -= 360;  // across the antimeridian
  if (dlon < -180) dlon += 360;
  fix.lon = a.lon + dlon * w;
  if (fix.lon > 180) fix.lon -= 360;
  if (fix.lon < -180) fix.lon += 360;
  fix.alt = lerp(a.alt, b.alt, w);
  fix.h_acc = lerp(a.h_acc, b.h_acc, w);
  fix.v_acc = lerp(a.v_acc, b.v_acc, w);
  if (a.satellites && b.satellites)
    fix.satellites = std::min(*a.satellites, *b.satellites);
  fix.source = a.source;
  return fix;
}

// One data row into *fixes; `first_line` catches an image listed twice.
void add_csv_row(std::string_view text, const CsvColumns& columns, int n,
                 std::map<std::string, GpsFix>* fixes,
                 std::map<std::string, int>* first_line) {
  auto cells = split_csv(text);
  std::string image(cell(cells, columns.image));
  if (image.empty()) throw std::runtime_error("no image name");
  if (auto [it, fresh] = first_line->emplace(image, n); !fresh)
    throw std::runtime_error(image + " is already on line " +
                             std::to_string(it->second));
  (*fixes)[image] = parse_csv_row(cells, columns);
}

}  // namespace

std::optional<std::int64_t> parse_time_utc(std::string_view s) {
  s = trim(s);
  std::size_t pos = 0;
  int y, mo, d, h, mi, sec;
  if (!digits(s, pos, 4, &y) || !expect(s, pos, "-") ||
      !digits(s, pos, 2, &mo) || !expect(s, pos, "-") ||
      !digits(s, pos, 2, &d) || !expect(s, pos, "Tt ") ||
      !digits(s, pos, 2, &h) || !expect(s, pos, ":") ||
      !digits(s, pos, 2, &mi) || !expect(s, pos, ":") ||
      !digits(s, pos, 2, &sec) || h > 23 || mi > 59 || sec > 60)
    return std::nullopt;
  if (pos < s.size() && s[pos] == '.') {
    std::size_t start = ++pos;
    while (pos < s.size() && s[pos] >= '0' && s[pos] <= '9') ++pos;
    if (pos == start) return std::nullopt;
  }
  auto offset = utc_offset(s, pos);
  namespace chr = std::chrono;
  chr::year_month_day date{chr::year{y}, chr::month(static_cast<unsigned>(mo)),
                           chr::day(static_cast<unsigned>(d))};
  if (!offset || !date.ok()) return std::nullopt;
  std::int64_t days = chr::sys_days(date).time_since_epoch().count();
  std::int64_t time_s = days * 86400 + h * 3600 + mi * 60 + sec - *offset;
  // An offset or a leap second can carry a time out of the years 0000 to
  // 9999, which format_time_utc cannot write as RFC 3339 again.
  constexpr std::int64_t kFirst = -62167219200;  // 0000-01-01T00:00:00Z
  constexpr std::int64_t kLast = 253402300799;   // 9999-12-31T23:59:59Z
  if (time_s < kFirst || time_s > kLast) return std::nullopt;
  return time_s;
}

std::string format_time_utc(std::int64_t time_s) {
  namespace chr = std::chrono;
  chr::sys_seconds t{chr::seconds(time_s)};
  auto day = chr::floor<chr::days>(t);
  chr::year_month_day date{day};
  chr::hh_mm_ss hms{t - day};
  char buf[48];
  std::snprintf(
      buf, sizeof buf, "%04d-%02u-%02uT%02d:%02d:%02dZ",
      static_cast<int>(date.year()), static_cast<unsigned>(date.month()),
      static_cast<unsigned>(date.day()), static_cast<int>(hms.hours().count()),
      static_cast<int>(hms.minutes().count()),
      static_cast<int>(hms.seconds().count()));
  return buf;
}

std::map<std::string, GpsFix> read_gps_csv(const std::string& path) {
  std::istringstream in(read_file(path));
  std::map<std::string, GpsFix> fixes;
  std::map<std::string, int> first_line;
  std::optional<CsvColumns> columns;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    std::string_view text = line;
    if (n == 1 && text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);
    if (trim(text).empty() || trim(text).starts_with('#')) continue;
    try {
      if (columns)
        add_csv_row(text, *columns, n, &fixes, &first_line);
      else
        columns = header_columns(text);
    } catch (const std::runtime_error& e) {
      throw std::runtime_error(path + ": line " + std::to_string(n) + ": " +
                               e.what());
    }
  }
  if (!columns) throw std::runtime_error(path + ": empty, no header line");
  return fixes;
}

std::vector<TrackPoint> read_gpx(const std::string& path) {
  std::string doc = read_file(path);
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

std::optional<GpsFix> fix_at(const std::vector<TrackPoint>& track,
                             std::int64_t time_s, std::int64_t max_gap_s) {
  if (track.empty()) return std::nullopt;
  if (time_s <= track.front().time_s) {
    if (track.front().time_s - time_s > max_gap_s) return std::nullopt;
    return track.front().fix;
  }
  if (time_s >= track.back().time_s) {
    if (time_s - track.back().time_s > max_gap_s) return std::nullopt;
    return track.back().fix;
  }
  auto after = std::upper_bound(
      track.begin(), track.end(), time_s,
      [](std::int64_t t, const TrackPoint& p) { return t < p.time_s; });
  const TrackPoint& a = *(after - 1);
  const TrackPoint& b = *after;
  double w = static_cast<double>(time_s - a.time_s) /
             static_cast<double>(b.time_s - a.time_s);
  GpsFix fix = interpolate(a.fix, b.fix, w);
  fix.time = format_time_utc(time_s);
  return fix;
}

}  // namespace arscout::ingest
