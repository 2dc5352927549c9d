// Static files served from directories: the web viewer, under the
// server's ServerOptions::static_mounts (ingest/server.h).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "arscout/http/http_types.h"

namespace arscout::http {

// Files under `directory` served without a token at `url_prefix` (ends in
// '/'), GET and HEAD only: the web viewer. A path ending in '/' serves its
// index.html; ".." segments, links out of the directory and anything but a
// regular file are 404.
struct StaticMount {
  std::string url_prefix;
  std::string directory;
};

// A GET or HEAD under one of `mounts` (the longest matching prefix), or
// nullopt when no mount covers the path.
std::optional<HttpResponse> serve_static(const std::vector<StaticMount>& mounts,
                                         const HttpRequest& request);

}  // namespace arscout::http
