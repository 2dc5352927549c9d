// The lines the scout prints: one per photo (docs/cli.md, "Output"), and
// the summary. Scripts and the CLI tests read them: keep them stable.
#include <cmath>
#include <sstream>

#include "arscout/documents/capture.h"
#include "scout_internal.h"

namespace arscout::scout {
namespace detail {

std::string describe_gps(const Json& gps) {
  std::ostringstream out;
  out << gps.value("source", "?");
  out.setf(std::ios::fixed);
  out.precision(1);
  if (auto it = gps.find("h_acc"); it != gps.end() && it->is_number())
    out << " ±" << it->get<double>() << " m";
  if (auto it = gps.find("satellites"); it != gps.end() && it->is_number())
    out << " " << it->get<int>() << " sat";
  return out.str();
}

std::string planned_gps(const std::optional<GpsFix>& fix,
                        const ExifInfo& exif) {
  if (fix) return describe_gps(to_json(*fix));
  return exif.gps ? describe_gps(to_json(*exif.gps)) : "none";
}

std::string stored_id(const HttpResult& answer, const std::string& sent) {
  try {
    const std::string path = answer.json().value("path", "");
    if (path.rfind("/captures/", 0) == 0) return path.substr(10);
  } catch (const std::exception&) {  // not JSON: the id sent stands
  }
  return sent;
}

std::optional<std::string> placed_site(const HttpResult& answer) {
  try {
    const std::string site = documents::capture_from_json(
                                 answer.json().value("attrs", Json::object()))
                                 .site;
    // It goes into a request path.
    if (!site.empty() && sanitise(site) == site) return site;
  } catch (const std::exception&) {  // no model line then
  }
  return std::nullopt;
}

std::string accepted_text(const HttpResult& answer, const std::string& id,
                          const std::string& gps_text, const std::string& why,
                          const std::optional<std::string>& model) {
  std::ostringstream text;
  Json doc;
  try {
    doc = answer.json();
  } catch (const std::exception&) {
    text << gps_text << "  " << answer.status << " " << id
         << " (unreadable answer)";
    return text.str();
  }
  const documents::Capture capture =
      documents::capture_from_json(doc.value("attrs", Json::object()));
  // "request" says less than our own description (csv or gpx).
  if (capture.gps && capture.gps->source == "request")
    text << gps_text;
  else
    text << (capture.gps ? describe_gps(to_json(*capture.gps)) : "none");
  text << (why.empty() ? "" : " (" + why + ")") << "  " << answer.status;
  if (answer.headers.count("idempotent-replay")) text << " replay";
  text << " " << id << " seq " << doc.value("seq", Json()).dump() << " "
       << (capture.status ? to_string(*capture.status) : "?");
  if (model) text << "  " << *model;
  return text.str();
}

std::string failed_text(const UploadOutcome& outcome,
                        const std::string& gps_text, const std::string& why) {
  return gps_text + (why.empty() ? "" : " (" + why + ")") + "  " +
         (outcome.answer ? std::to_string(outcome.answer->status) + " " +
                               answer_error_text(*outcome.answer)
                         : "network error: " + outcome.error);
}

}  // namespace detail

std::string answer_error_text(const HttpResult& answer) {
  try {
    Json j = answer.json();
    if (j.is_object() && j.contains("error"))
      return j.value("error", "") + ": " + j.value("message", "");
  } catch (const std::exception&) {  // not the API's error form
  }
  std::string text = "HTTP " + std::to_string(answer.status);
  if (!answer.body.empty()) text += ": " + answer.body.substr(0, 200);
  return text;
}

std::string scout_summary(const ScoutTotals& totals, std::size_t left_over) {
  std::ostringstream text;
  text << totals.succeeded << " of " << totals.succeeded + totals.failed
       << " photos uploaded (" << totals.bytes_sent << " B), " << totals.failed
       << " failed";
  if (left_over > 0)
    text << (totals.refused ? ", token refused" : ", interrupted") << " before "
         << left_over << " more";
  return text.str();
}

}  // namespace arscout::scout
