// `arscout serve` as a process of its own, for the load and fault tests:
// they need its memory figures, and to keep it running while its database
// goes away underneath it.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "tool_process.h"

namespace arscout::testing {

class ServeProcess {
 public:
  // Starts `arscout serve --db URL --listen 127.0.0.1:0 --web-root ""` plus
  // extra (an --web-root there replaces the default; --log-level goes
  // before the command), logging
  // to log, and waits (up to 30 s) for its "serving ... at URL" line.
  // Throws std::runtime_error, with the log, when it does not come.
  ServeProcess(const std::string& cli, const std::string& db_url,
               const std::string& log,
               const std::vector<std::string>& extra = {});

  const std::string& url() const { return url_; }
  ToolProcess& process() { return *process_; }
  // From /proc: the largest and the current resident set, in KiB.
  std::int64_t peak_rss_kib() const;
  std::int64_t rss_kib() const;

 private:
  std::int64_t status_field_kib(const std::string& field) const;

  std::unique_ptr<ToolProcess> process_;
  std::string log_, url_;
};

// A distinct JPEG of about width x height noise (seeded, so a retry sends
// the same bytes), roughly 0.7 bytes per pixel at this quality.
std::string noise_jpeg(int seed, int width, int height);

}  // namespace arscout::testing
