// Which files are photos, in which order they go, and the capture id each
// is sent under.
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <ostream>

#include "scout_internal.h"

namespace arscout::scout {
namespace {

namespace fs = std::filesystem;

std::string lower(std::string s) {
  for (char& c : s)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// FNV-1a: a stable short hash with no dependency (std::hash may change, and
// the id must not, or a re-run would store the photo twice).
std::string short_hash(std::string_view s, int hex_digits) {
  std::uint64_t h = 14695981039346656037ull;
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return std::string(buf, hex_digits);
}

void sort_by_file_name(std::vector<fs::path>& files) {
  std::stable_sort(files.begin(), files.end(),
                   [](const fs::path& a, const fs::path& b) {
                     return a.filename().string() < b.filename().string();
                   });
}

}  // namespace

namespace detail {

std::string sanitise(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '-' &&
        c != '_')
      c = '_';
  return out;
}

std::string content_type(const std::string& bytes, const fs::path& path) {
  if (bytes.starts_with("\x89PNG")) return "image/png";
  if (bytes.starts_with("\xFF\xD8\xFF")) return "image/jpeg";
  return lower(path.extension().string()) == ".png" ? "image/png"
                                                    : "image/jpeg";
}

}  // namespace detail

std::string scout_capture_id(std::string_view scout_name,
                             std::string_view file_name) {
  std::string id =
      (scout_name.empty() ? "" : detail::sanitise(scout_name) + ".") +
      detail::sanitise(file_name);
  constexpr std::size_t kMax = 128;  // the server's limit on capture_id
  if (id.size() > kMax) id = id.substr(0, kMax - 13) + "-" + short_hash(id, 12);
  return id;
}

bool is_photo_file(const fs::path& path) {
  std::string name = path.filename().string();
  std::string ext = lower(path.extension().string());
  return !name.starts_with('.') &&
         (ext == ".jpg" || ext == ".jpeg" || ext == ".png");
}

std::vector<fs::path> list_photos(const std::string& dir, std::ostream& err) {
  std::vector<fs::path> photos;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end;
       it.increment(ec)) {
    if (it->is_regular_file(ec) && is_photo_file(it->path()))
      photos.push_back(it->path());
  }
  // While watching, the folder may not be there yet, or any more.
  if (ec) err << "arscout: cannot list " << dir << ": " << ec.message() << "\n";
  sort_by_file_name(photos);
  return photos;
}

std::vector<fs::path> sorted_by_file_name(
    const std::vector<std::string>& files) {
  std::vector<fs::path> paths(files.begin(), files.end());
  sort_by_file_name(paths);
  return paths;
}

}  // namespace arscout::scout
