#include "arscout/ingest/session.h"

#include <chrono>
#include <fstream>
#include <set>
#include <stdexcept>
#include <thread>

#include "api_handlers.h"
#include "arscout/documents/capture.h"
#include "arscout/util/base64.h"
#include "arscout/util/error.h"
#include "arscout/util/time.h"

namespace arscout::ingest {
namespace {

// Attributes the engine sets on a capture after the upload.
const char* const kEngineFields[] = {"site", "status", "status_reason"};

// Which input a change is, judged by the document as it is now; "" for
// the engine's outputs and everything else.
std::string input_kind(const db::Change& c,
                       const std::optional<db::Document>& doc) {
  const bool capture = c.path.rfind("/captures/", 0) == 0;
  if (capture && c.op == db::OpType::kPut && c.version == 1) return "capture";
  if (capture && c.op == db::OpType::kPatch && doc) {
    const documents::Capture now = documents::capture_from_json(doc->attrs);
    if (now.status == documents::CaptureStatus::kWithdrawn &&
        now.status_reason == "withdrawn by " + c.author)
      return "withdrawal";
  }
  if (c.path.rfind("/cameras/", 0) == 0 && c.op == db::OpType::kPut)
    return "camera";
  return "";
}

class SessionWriter {
 public:
  SessionWriter(db::Store& store, std::ostream& out)
      : store_(store), out_(out) {}

  void change(const db::Change& c, SessionSummary* summary) {
    Json line = to_json(c);
    line["type"] = "change";
    line["time_us"] = c.time_us;
    const auto doc =
        c.op == db::OpType::kDelete ? std::nullopt : store_.get(c.path);
    const std::string input = input_kind(c, doc);
    if (!input.empty() && doc) {
      Json attrs = doc->attrs;
      if (input == "capture")
        for (const char* field : kEngineFields) attrs.erase(field);
      line["input"] = input;
      line["attrs"] = attrs;
      line["blobs"] = doc->blobs;
      for (const auto& [name, hash] : doc->blobs) blob(hash, summary);
      ++summary->inputs;
    }
    out_ << line.dump() << '\n';
    ++summary->changes;
  }

 private:
  void blob(const std::string& hash, SessionSummary* summary) {
    if (!written_.insert(hash).second) return;
    const std::string bytes = store_.get_blob(hash);
    out_ << Json{{"type", "blob"},
                 {"sha256", hash},
                 {"size", bytes.size()},
                 {"base64", util::to_base64(bytes)}}
                .dump()
         << '\n';
    ++summary->blobs;
    summary->blob_bytes += static_cast<std::int64_t>(bytes.size());
  }

  db::Store& store_;
  std::ostream& out_;
  std::set<std::string> written_;
};

// ---- replay

// A replay waits as long as the session took: its changes' times must
// read as microseconds that never go back, over at most 30 days
// (a file saying 10^18 us would otherwise wait until killed).
constexpr std::int64_t kMaxSessionSpanUs = 30ll * 24 * 3600 * 1000000;

struct SessionTimes {
  std::int64_t first = -1, last = -1;
};

template <typename Refuse>
void check_time(const Json& value, SessionTimes* times, const Refuse& refuse) {
  if (!value.is_number_integer() || value.get<std::int64_t>() < 0)
    return refuse("time_us is not a non-negative integer");
  const std::int64_t t = value.get<std::int64_t>();
  if (times->first < 0) times->first = t;
  if (t < times->last) refuse("time_us goes back in time");
  if (t - times->first > kMaxSessionSpanUs)
    refuse("the session spans more than 30 days (time_us " + std::to_string(t) +
           ")");
  times->last = t;
}

[[noreturn]] void bad_line(const std::string& path, std::int64_t line,
                           const std::string& what) {
  throw std::runtime_error(path + ":" + std::to_string(line) + ": " + what);
}

// Parses every line and checks the frame (header first, end last, counts
// agree) before anything is applied.
void check_session(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot read");
  std::string text;
  std::int64_t line = 0, changes = 0, blobs = 0;
  SessionTimes times;
  bool ended = false;
  while (std::getline(in, text)) {
    ++line;
    if (ended) bad_line(path, line, "text after the end record");
    Json j = Json::parse(text, nullptr, false);
    if (j.is_discarded() || !j.is_object())
      bad_line(path, line, "not a JSON object");
    const std::string type = j.value("type", "");
    if (line == 1) {
      if (type != "session" || j.value("format", "") != "arscout-session")
        bad_line(path, line, "not an arscout session file");
      if (j.value("version", 0) != 1)
        bad_line(path, line,
                 "session format version " + j.value("version", Json()).dump() +
                     " is not supported (1 is)");
    } else if (type == "change") {
      if (!j.contains("seq") || !j.contains("path") || !j.contains("time_us"))
        bad_line(path, line, "a change needs seq, path and time_us");
      check_time(j.at("time_us"), &times,
                 [&](const std::string& why) { bad_line(path, line, why); });
      ++changes;
    } else if (type == "blob") {
      ++blobs;
    } else if (type == "end") {
      if (j.value("changes", -1) != changes || j.value("blobs", -1) != blobs)
        bad_line(path, line, "the end record's counts do not match the file");
      ended = true;
    } else {
      bad_line(path, line, "unknown record type '" + type + "'");
    }
  }
  if (!ended)
    bad_line(path, line, "the file ends without its end record (truncated?)");
}

// The upload a scout made: image bytes and the metadata header.
HttpRequest upload_request(const std::string& id, const Json& attrs,
                           const std::string& image) {
  const documents::Capture capture = documents::capture_from_json(attrs);
  Json meta{{"capture_id", id}};
  for (const auto& [key, value] : {std::pair{"camera", &capture.camera},
                                   {"site_hint", &capture.site_hint},
                                   {"filename", &capture.filename},
                                   {"taken", &capture.taken}})
    if (!value->empty()) meta[key] = *value;
  // A fix read from the EXIF is read again; one the scout sent is sent.
  if (capture.gps && capture.gps->source == "request") {
    meta["gps"] = documents::to_json(*capture.gps);
    meta["gps"].erase("source");
  }
  HttpRequest req;
  req.method = "POST";
  req.path = req.target = "/v1/captures";
  req.headers["content-type"] =
      capture.format == "png" ? "image/png" : "image/jpeg";
  req.headers["x-capture-metadata"] = meta.dump();
  req.body = image;
  return req;
}

class Replayer {
 public:
  Replayer(db::Store& store, const ReplayOptions& options)
      : store_(store), options_(options) {}

  void blob(const Json& j) {
    const auto bytes = util::from_base64(j.at("base64").get<std::string>());
    if (!bytes || bytes->size() != j.at("size").get<size_t>())
      throw std::runtime_error("blob " + j.value("sha256", "") +
                               ": bad base64 or size");
    if (store_.put_blob(*bytes) != j.at("sha256"))
      throw std::runtime_error("blob " + j.value("sha256", "") +
                               ": the bytes do not match their hash");
  }

  void change(const Json& j, ReplaySummary* summary) {
    ++summary->changes_read;
    const std::string input = j.value("input", "");
    if (input.empty()) return;
    pace(j.at("time_us").get<std::int64_t>());
    const std::string path = j.at("path");
    const Json& attrs = j.at("attrs");
    HttpResponse r;
    // Each input is made again as the API would take it from its scout:
    // with a scout's rights under the recorded name, which must be one a
    // token could have (a withdrawal or camera of another scout's is then
    // refused, as it would have been).
    if (input == "capture") {
      const Principal scout{Role::kScout, attrs.value("scout", "")};
      r = call(scout, [&](ApiContext& ctx) {
        return post_capture(
            ctx,
            upload_request(
                path.substr(10), attrs,
                store_.get_blob(j.at("blobs").at("image").get<std::string>())));
      });
      if (r.status / 100 == 2) ++summary->captures;
    } else if (input == "withdrawal") {
      const Principal who{Role::kScout, j.value("author", "")};
      r = call(who, [&](ApiContext& ctx) {
        return withdraw_capture(ctx, HttpRequest{}, path.substr(10));
      });
      if (r.status / 100 == 2) ++summary->withdrawals;
    } else if (input == "camera" && same_document(path, attrs)) {
      r.status = 200;  // a second replay: PUT would only add a version
      ++summary->cameras;
    } else if (input == "camera") {
      const Principal who{Role::kScout, j.value("author", "")};
      HttpRequest req;
      req.method = "PUT";
      req.body = attrs.dump();
      r = call(who, [&](ApiContext& ctx) {
        return put_camera(ctx, req, path.substr(9));
      });
      if (r.status / 100 == 2) ++summary->cameras;
    }
    if (r.status / 100 != 2) ++summary->failed;
    if (options_.progress) options_.progress(path, r.status);
  }

 private:
  bool same_document(const std::string& path, const Json& attrs) {
    const auto doc = store_.get(path);
    return doc && doc->attrs == attrs;
  }

  template <typename Handler>
  HttpResponse call(const Principal& who, Handler handler) {
    if (std::string problem = token_name_problem(who.name); !problem.empty())
      return HttpResponse::error(
          403, "forbidden", "recorded author '" + who.name + "': " + problem);
    ApiContext ctx{store_, metrics_, who};
    try {
      return handler(ctx);
    } catch (const db::StoreError& e) {
      return error_response(e);
    } catch (const util::Error& e) {
      return error_response(e);
    }
  }

  // Sleeps so that inputs arrive as far apart as they were recorded,
  // divided by the speed.
  void pace(std::int64_t time_us) {
    const auto now = std::chrono::steady_clock::now();
    if (first_us_ < 0) {
      first_us_ = time_us;
      start_ = now;
      return;
    }
    if (options_.fast) return;
    const auto due =
        start_ + std::chrono::microseconds(static_cast<std::int64_t>(
                     (time_us - first_us_) / std::max(options_.speed, 1e-6)));
    while (std::chrono::steady_clock::now() < due &&
           !(options_.stop && options_.stop()))
      std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(
          due - std::chrono::steady_clock::now(),
          std::chrono::milliseconds(100)));
  }

  db::Store& store_;
  const ReplayOptions& options_;
  Metrics metrics_;
  std::int64_t first_us_ = -1;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace

SessionSummary export_session(
    db::Store& store, std::int64_t since, std::ostream& out,
    const std::function<void(const SessionSummary&)>& progress) {
  SessionSummary summary;
  summary.first_seq = since;
  const std::int64_t last = store.last_seq();
  out << Json{{"type", "session"},
              {"format", "arscout-session"},
              {"version", 1},
              {"since", since},
              {"last_seq", last},
              {"backend", store.backend()},
              {"exported", util::format_time_utc(std::time(nullptr))}}
             .dump()
      << '\n';
  SessionWriter writer(store, out);
  std::int64_t after = since;
  while (after < last) {
    const auto page = store.changes(after, "/**", 500);
    if (page.empty()) break;
    for (const db::Change& c : page) {
      if (c.seq > last) break;
      writer.change(c, &summary);
      summary.last_seq = c.seq;
      if (progress) progress(summary);
    }
    after = page.back().seq;
  }
  out << Json{{"type", "end"},
              {"changes", summary.changes},
              {"blobs", summary.blobs}}
             .dump()
      << '\n';
  if (!out) throw std::runtime_error("cannot write the session file");
  return summary;
}

ReplaySummary replay_session(const std::string& path, db::Store& store,
                             const ReplayOptions& options) {
  check_session(path);
  const auto start = std::chrono::steady_clock::now();
  std::ifstream in(path);
  Replayer replayer(store, options);
  ReplaySummary summary;
  std::string text;
  std::int64_t line = 0;
  while (std::getline(in, text) && !(options.stop && options.stop())) {
    ++line;
    const Json j = Json::parse(text);
    const std::string type = j.value("type", "");
    try {
      if (type == "blob") replayer.blob(j);
      if (type == "change") replayer.change(j, &summary);
    } catch (const Json::exception& e) {
      bad_line(path, line, e.what());
    }
  }
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  return summary;
}

}  // namespace arscout::ingest
