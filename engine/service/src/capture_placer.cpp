#include "capture_placer.h"

#include <optional>

#include "arscout/db/path.h"
#include "arscout/db/store.h"
#include "arscout/util/time.h"
#include "capture_document.h"

namespace arscout::engine::service {
namespace {

// A photo's own time: when it was taken, else when it was received.
std::int64_t taken_s(const documents::Capture& capture) {
  if (auto t = util::parse_time_utc(capture.taken)) return *t;
  return util::parse_time_utc(capture.received).value_or(0);
}

}  // namespace

std::vector<std::pair<std::string, Work>> CapturePlacer::place(
    const db::Change& change) {
  // Its own status updates need no work.
  if (change.op == db::OpType::kDelete || change.author == board_.options.name)
    return {};
  auto doc = board_.store.get(change.path);
  if (!doc || doc->kind != "capture") return {};
  const std::string id(db::leaf_name(change.path));
  const documents::Capture capture = documents::capture_from_json(doc->attrs);
  if (capture.status == documents::CaptureStatus::kWithdrawn) {
    auto site = board_.directory.site_of(id);
    if (!site) return {};
    return {
        {*site, Work{Work::Kind::kWithdraw, id, change.seq, capture.scout}}};
  }
  if (capture.status != documents::CaptureStatus::kStored &&
      capture.status != documents::CaptureStatus::kNeedsGps)
    return unsaved_work(change, id, capture);
  // The engine patches `site` in the batch that commits the capture into
  // its site's state: a capture carrying it (a photo still waiting for
  // neighbours, as another worker published it) needs nothing more.
  if (!capture.site.empty() && board_.directory.site_of(id) == capture.site)
    return {};
  return place_new(change, id, capture);
}

// A capture placed before (the change seen again after a restart) goes to
// its site again: the site's state says whether it was processed.
std::vector<std::pair<std::string, Work>> CapturePlacer::place_new(
    const db::Change& change, const std::string& id,
    const documents::Capture& capture) {
  SiteDirectory& directory = board_.directory;
  const auto fix = geo_fix(capture.gps);
  const std::int64_t taken = taken_s(capture);
  std::optional<std::string> site;
  if (fix || !capture.site_hint.empty())
    site = directory.place(id, fix, capture.site_hint,
                           default_site_name(capture, taken));
  else if (auto near = trails_.site_near(capture.scout, taken))
    site = directory.place_in(id, *near);
  if (!site) return wait_for_position(change, id, capture, taken);
  trails_.placed(capture.scout, taken, *site);
  {
    std::lock_guard lock(board_.mutex);
    ++board_.stats.captures_placed;
  }
  board_.log("capture " + id + " -> site " + *site);
  std::vector<std::pair<std::string, Work>> work{
      {*site, Work{Work::Kind::kAdd, id, change.seq, capture.scout}}};
  // Its scout's photos that waited for a position follow it.
  for (const std::string& waited : trails_.release(capture.scout, taken))
    if (auto to = directory.place_in(waited, *site)) {
      board_.log("capture " + waited + " -> site " + *to + " (by " +
                 capture.scout + "'s photos)");
      work.push_back(
          {*to, Work{Work::Kind::kAdd, waited, change.seq, capture.scout}});
    }
  // Sites whose footprints this fix reaches too grow into this one.
  if (fix) {
    for (const std::string& other : directory.meeting(*site, *fix))
      work.push_back({*site, Work{Work::Kind::kMerge, other, change.seq, ""}});
  }
  return work;
}

// A capture with no fix, no hint and no photo of its scout's placed within
// the trails' window: kept (not rejected) until one is.
std::vector<std::pair<std::string, Work>> CapturePlacer::wait_for_position(
    const db::Change& change, const std::string& id,
    const documents::Capture& capture, std::int64_t taken) {
  trails_.wait(capture.scout, taken, id);
  board_.store.batch({db::WriteOp::patch(
      change.path,
      documents::status_patch(
          documents::CaptureStatus::kNeedsGps,
          "waiting for a position: no GPS fix, no site hint, and no photo "
          "of " +
              capture.scout + "'s placed within " +
              std::to_string(trails_.window_s() / 60) +
              " minutes of it yet"))});
  board_.log("capture " + id + ": waiting for a position");
  return {};
}

// A capture an earlier run committed into a model (its status says where it
// went) while the site's engine state was left unsaved (WorkerOptions::
// state_interval): the saved state has not folded this change in, so it is
// added again; else nothing. A capture the state holds after all is
// skipped by the increment.
std::vector<std::pair<std::string, Work>> CapturePlacer::unsaved_work(
    const db::Change& change, const std::string& id,
    const documents::Capture& capture) {
  if (capture.status == documents::CaptureStatus::kRejected) return {};
  const auto site = board_.directory.site_of(id);
  if (!site || change.seq <= leases_.settled_through(*site)) return {};
  return {{*site, Work{Work::Kind::kAdd, id, change.seq, capture.scout}}};
}

std::string default_site_name(const documents::Capture& capture,
                              std::int64_t taken) {
  std::string when = util::format_time_utc(taken);  // 2026-12-06T14:05:09Z
  when = when.substr(0, 16);
  if (when.size() > 10) when[10] = ' ';
  return (capture.scout.empty() ? std::string("site") : capture.scout) + " " +
         when;
}

}  // namespace arscout::engine::service
