// The status of a capture: the one list of its words (docs/api.md), for
// the API, the engine, the engine service, the viewer and the CLI. The
// viewer's and the scout app's JavaScript name the same words once, in
// viewer/web/capture_status.js (CaptureStatusWords checks that they agree).
//
// Two documents carry a status, with different words for a photo the
// engine holds but has not placed in the model:
//  - /captures/{id} "status": stored (with a GPS fix) or needs-gps
//    (without) as uploaded; then registered or rejected from the engine,
//    and stored again while the site waits for more captures (the engine's
//    pending, published as stored: capture_document_status); withdrawn by
//    the scout or an admin.
//  - /sites/{id}/model "captures": registered, pending or rejected, the
//    engine's own view of each photo.
// Stored data holds both words in their documents, so neither is renamed.
#pragma once

#include <optional>
#include <string_view>

namespace arscout::documents {

// The engine's images take only the first three; their order is that of
// the engine state's bytes (engine/io/serialization.cpp), so it is fixed.
enum class CaptureStatus {
  kRegistered = 0,
  kPending = 1,
  kRejected = 2,
  kStored,
  kNeedsGps,
  kWithdrawn,
};

namespace detail {
struct CaptureStatusWord {
  CaptureStatus status;
  const char* word;
};
inline constexpr CaptureStatusWord kCaptureStatusWords[] = {
    {CaptureStatus::kRegistered, "registered"},
    {CaptureStatus::kPending, "pending"},
    {CaptureStatus::kRejected, "rejected"},
    {CaptureStatus::kStored, "stored"},
    {CaptureStatus::kNeedsGps, "needs-gps"},
    {CaptureStatus::kWithdrawn, "withdrawn"},
};
}  // namespace detail

// The stored word of a status, e.g. "needs-gps".
constexpr const char* to_string(CaptureStatus status) {
  for (const auto& [s, word] : detail::kCaptureStatusWords)
    if (s == status) return word;
  return "";  // not reached: every status has its word
}

// The status a word names; nullopt for any other word (a lenient reader's
// answer to a document written by another version).
constexpr std::optional<CaptureStatus> capture_status_of(
    std::string_view word) {
  for (const auto& [s, w] : detail::kCaptureStatusWords)
    if (word == w) return s;
  return std::nullopt;
}

// The status a word names. Throws DocumentError naming the word and the
// words there are when it names none.
CaptureStatus parse_capture_status(std::string_view word);

// The status a capture's document says for what the engine holds: its
// pending is published as stored (the site waits for more captures).
constexpr CaptureStatus capture_document_status(CaptureStatus engine) {
  return engine == CaptureStatus::kPending ? CaptureStatus::kStored : engine;
}

// Site, model statistics and engine state documents count registered
// captures under the status word itself (docs/api.md).
inline constexpr const char* kRegisteredCount =
    to_string(CaptureStatus::kRegistered);

}  // namespace arscout::documents
