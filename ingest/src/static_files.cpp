// Static files (the web viewer) under ServerOptions::static_mounts.
#include <filesystem>
#include <fstream>
#include <sstream>

#include "api.h"

namespace arscout::ingest {
namespace {

namespace fs = std::filesystem;

std::string content_type_of(const fs::path& file) {
  static const std::map<std::string, std::string> kTypes = {
      {".html", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".json", "application/json"},
      {".webmanifest", "application/manifest+json"},
      {".map", "application/json"},
      {".png", "image/png"},
      {".jpg", "image/jpeg"},
      {".svg", "image/svg+xml"},
      {".ico", "image/x-icon"},
      {".wasm", "application/wasm"},
      {".txt", "text/plain; charset=utf-8"}};
  auto it = kTypes.find(file.extension().string());
  return it == kTypes.end() ? "application/octet-stream" : it->second;
}

// No "." or ".." segments, backslashes or NULs: the path names a file
// below the mount as written (links are checked after resolving).
bool safe_relative(const std::string& relative) {
  if (relative.find('\\') != std::string::npos ||
      relative.find('\0') != std::string::npos)
    return false;
  std::stringstream in(relative);
  std::string segment;
  while (std::getline(in, segment, '/'))
    if (segment == ".." || segment == ".") return false;
  return true;
}

const StaticMount* longest_mount(const std::vector<StaticMount>& mounts,
                                 const std::string& path) {
  const StaticMount* best = nullptr;
  for (const StaticMount& m : mounts)
    if (path.compare(0, m.url_prefix.size(), m.url_prefix) == 0 &&
        (!best || m.url_prefix.size() > best->url_prefix.size()))
      best = &m;
  return best;
}

HttpResponse not_found(const std::string& path) {
  return HttpResponse::error(404, "not_found", "no file " + path);
}

// A folder with a page, named without its slash (/scout): the browser is
// sent to /scout/, so the page's relative links resolve inside it.
HttpResponse to_folder(const std::string& path) {
  HttpResponse r;
  r.status = 301;
  r.content_type = "text/plain; charset=utf-8";
  r.headers.emplace_back("Location", path + "/");
  r.body = "moved to " + path + "/\n";
  return r;
}

}  // namespace

std::optional<HttpResponse> serve_static(const std::vector<StaticMount>& mounts,
                                         const HttpRequest& req) {
  const StaticMount* mount = longest_mount(mounts, req.path);
  if (!mount) return std::nullopt;
  if (req.method != "GET" && req.method != "HEAD") {
    HttpResponse r = HttpResponse::error(405, "method_not_allowed",
                                         "static files allow GET, HEAD");
    r.headers.emplace_back("Allow", "GET, HEAD");
    return r;
  }
  std::string relative = req.path.substr(mount->url_prefix.size());
  if (relative.empty() || relative.back() == '/') relative += "index.html";
  if (!safe_relative(relative)) return not_found(req.path);
  std::error_code ec;
  const fs::path root = fs::canonical(mount->directory, ec);
  if (ec) return not_found(req.path);
  const fs::path file = fs::canonical(root / relative, ec);
  if (!ec && fs::is_regular_file(file / "index.html"))
    return to_folder(req.path);
  if (ec || !fs::is_regular_file(file)) return not_found(req.path);
  // A symbolic link must not lead out of the mounted folder.
  auto [r, f] = std::mismatch(root.begin(), root.end(), file.begin());
  if (r != root.end()) return not_found(req.path);
  std::ifstream in(file, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (!in.good() && !in.eof()) return not_found(req.path);
  HttpResponse response;
  response.content_type = content_type_of(file);
  response.headers.emplace_back("Cache-Control", "no-cache");
  response.body = bytes.str();
  return response;
}

}  // namespace arscout::ingest
