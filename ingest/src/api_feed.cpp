// /v1/changes: the change log, with long-polling.
#include <chrono>

#include "api_handlers.h"

namespace arscout::ingest {

HttpResponse get_changes(ApiContext& ctx, const HttpRequest& req) {
  std::string error;
  auto since = int_param(req, "since", 0, 0, INT64_MAX, &error);
  auto limit =
      since ? int_param(req, "limit", 1000, 1, 10000, &error) : std::nullopt;
  auto wait = limit ? int_param(req, "wait", 0, 0, 60, &error) : std::nullopt;
  if (!wait) return HttpResponse::error(400, "bad_request", error);
  std::string pattern = "/**";
  if (auto it = req.query.find("pattern"); it != req.query.end())
    pattern = it->second;

  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::seconds(*wait);
  std::vector<db::Change> changes;
  std::int64_t head = 0;
  std::int64_t after = *since;
  while (true) {
    head = ctx.store.last_seq();
    changes =
        ctx.store.changes(after, pattern, static_cast<std::size_t>(*limit));
    const std::int64_t last = changes.empty() ? after : changes.back().seq;
    // The feed shows only what the caller may read as a document.
    std::erase_if(changes, [&](const db::Change& c) {
      return !can_read(ctx.who, c.path);
    });
    if (!changes.empty() || Clock::now() >= deadline) break;
    if (last > after) {  // all hidden: look past them without waiting
      after = last;
      continue;
    }
    if (req.may_park) {  // the server waits without a thread, then asks again
      HttpResponse parked;
      parked.park_after = head;
      return parked;
    }
    auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - Clock::now());
    ctx.store.wait_for_change(head,
                              std::min(left, std::chrono::milliseconds(1000)));
  }
  Json out = Json::array();
  for (const auto& c : changes) out.push_back(to_json(c));
  return HttpResponse::json(200, Json{{"changes", out}, {"last_seq", head}});
}

}  // namespace arscout::ingest
