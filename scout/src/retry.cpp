// When an upload is tried again, and after how long (docs/cli.md,
// "Retries").
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "scout_internal.h"

namespace arscout::scout {

bool is_retryable_status(int status) {
  // 408 and 429 say "later", 5xx "not now"; every other 4xx will not change.
  return status >= 500 || status == 408 || status == 429;
}

double retry_delay_s(int retry, const HttpResult* answer) {
  double delay = std::min(0.5 * std::pow(2.0, retry), 8.0);
  if (answer) {
    auto it = answer->headers.find("retry-after");
    if (it != answer->headers.end()) {
      // Capped: a misconfigured server must not park the scout for hours.
      double after = std::atof(it->second.c_str());
      if (after > delay) delay = std::min(after, 60.0);
    }
  }
  return delay;
}

namespace detail {

std::string retry_note(const std::string& name, const UploadOutcome& outcome,
                       int retry, int retries, double delay_s) {
  std::ostringstream note;
  note << "  " << name << ": "
       << (outcome.answer ? answer_error_text(*outcome.answer) : outcome.error)
       << "; retry " << retry + 1 << "/" << retries << " in " << delay_s
       << " s\n";
  return note.str();
}

}  // namespace detail
}  // namespace arscout::scout
