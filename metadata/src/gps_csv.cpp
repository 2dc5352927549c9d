// GPS fixes from a CSV a scout brings along: one row per photo, matched by
// file name (read_gps_csv, gps.h).
#include <map>
#include <sstream>
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

std::map<std::string, GpsFix> read_gps_csv(const std::string& path) {
  std::istringstream in(util::read_file(path));
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

}  // namespace arscout::metadata
