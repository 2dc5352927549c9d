#include "arscout/documents/capture_status.h"

#include <string>

#include "arscout/documents/document_error.h"

namespace arscout::documents {

CaptureStatus parse_capture_status(std::string_view word) {
  if (std::optional<CaptureStatus> status = capture_status_of(word))
    return *status;
  // Appended, not added up: GCC 12 warns (-Wrestrict) on the sum.
  std::string message = "'";
  message.append(word).append("' is not a capture status (");
  const char* separator = "";
  for (const auto& [status, w] : detail::kCaptureStatusWords) {
    message.append(separator).append(w);
    separator = ", ";
  }
  throw DocumentError(message.append(")"));
}

}  // namespace arscout::documents
