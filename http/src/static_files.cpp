// Static files (the web viewer) under ServerOptions::static_mounts.
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "arscout/http/static_files.h"
#include "arscout/util/base64.h"

namespace arscout::http {
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

// No empty, "." or ".." segments, backslashes or NULs: the path names a
// file below the mount as written (links are checked after resolving). An
// empty segment would make "//srv/web" an absolute path, which joined to
// the mount's folder replaces it.
bool safe_relative(const std::string& relative) {
  if (relative.find('\\') != std::string::npos ||
      relative.find('\0') != std::string::npos)
    return false;
  std::stringstream in(relative);
  std::string segment;
  while (std::getline(in, segment, '/'))
    if (segment.empty() || segment == ".." || segment == ".") return false;
  return true;
}

// The hashes of a page's inline scripts (its import map), for its
// Content-Security-Policy: only those and the site's own files run.
std::string inline_script_sources(const std::string& page) {
  std::string sources;
  for (std::size_t at = page.find("<script"); at != std::string::npos;
       at = page.find("<script", at + 1)) {
    const std::size_t open_end = page.find('>', at);
    const std::size_t close = page.find("</script>", at);
    if (open_end == std::string::npos || close == std::string::npos ||
        close < open_end)
      break;
    if (page.substr(at, open_end - at).find(" src=") != std::string::npos)
      continue;
    sources += " 'sha256-" +
               util::sha256_base64(std::string_view(page).substr(
                   open_end + 1, close - open_end - 1)) +
               "'";
  }
  return sources;
}

// What a browser is told about every file of the web viewer and the scout
// app: no framing by other sites (clickjacking), no guessing of types, no
// script or connection beyond this origin (the pages load nothing from
// elsewhere), no referrer with tokens in it.
void add_security_headers(HttpResponse& response, const std::string& body,
                          bool is_page) {
  response.headers.emplace_back("X-Frame-Options", "DENY");
  response.headers.emplace_back("Referrer-Policy", "no-referrer");
  response.headers.emplace_back(
      "Content-Security-Policy",
      "default-src 'self'; script-src 'self'" +
          (is_page ? inline_script_sources(body) : std::string()) +
          "; style-src 'self' 'unsafe-inline'; img-src 'self' data: blob:; "
          "media-src 'self' blob: mediastream:; connect-src 'self' ws: wss:; "
          "worker-src 'self'; object-src 'none'; base-uri 'none'; "
          "frame-ancestors 'none'; form-action 'self'");
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
  if (ec) return not_found(req.path);
  // A symbolic link must not lead out of the mounted folder, and no
  // redirect names a folder outside it.
  auto [r, f] = std::mismatch(root.begin(), root.end(), file.begin());
  if (r != root.end()) return not_found(req.path);
  if (fs::is_regular_file(file / "index.html")) return to_folder(req.path);
  if (!fs::is_regular_file(file)) return not_found(req.path);
  std::ifstream in(file, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (!in.good() && !in.eof()) return not_found(req.path);
  HttpResponse response;
  response.content_type = content_type_of(file);
  response.headers.emplace_back("Cache-Control", "no-cache");
  response.body = bytes.str();
  add_security_headers(response, response.body, file.extension() == ".html");
  return response;
}

}  // namespace arscout::http
