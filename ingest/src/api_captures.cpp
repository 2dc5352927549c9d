// POST /v1/captures and DELETE /v1/captures/{id}: a scout's photos.
#include <chrono>
#include <ctime>

#include "api_handlers.h"
#include "arscout/db/path.h"
#include "arscout/documents/capture.h"
#include "arscout/http/multipart.h"
#include "arscout/metadata/gps.h"
#include "arscout/util/sha256.h"
#include "image_probe.h"

namespace arscout::ingest {

// A capture's fix and EXIF (arscout/metadata/gps.h).
using metadata::ExifInfo;
using metadata::format_time_utc;
using metadata::gps_from_json;
using metadata::GpsFix;
using metadata::parse_time_utc;
using metadata::read_exif;
using metadata::validate_gps;

namespace {

// Metadata is a few fields (docs/api.md); the cap keeps a part of up to
// --max-body-mb from becoming a JSON value hundreds of times its size in
// memory (a 60 MB array of zeros took 1.5 GB).
constexpr std::size_t kMaxMetadataBytes = 64 * 1024;

HttpResponse metadata_too_large() {
  return HttpResponse::error(413, "payload_too_large",
                             "capture metadata is at most 64 KiB");
}

struct Upload {
  std::string_view image;
  Json meta = Json::object();
};

// Splits the request into image bytes and metadata; an error response when
// the body or metadata is malformed.
std::optional<HttpResponse> read_upload(const HttpRequest& req, Upload* up) {
  std::string error;
  std::string meta_text;
  std::string boundary = http::multipart_boundary(req.header("content-type"));
  if (!boundary.empty()) {
    auto parts = http::parse_multipart(req.body, boundary, &error);
    if (!parts) return HttpResponse::error(400, "bad_request", error);
    bool has_image = false, has_metadata = false;
    for (const http::FormPart& p : *parts) {
      bool& seen = p.name == "image" ? has_image : has_metadata;
      if (p.name != "image" && p.name != "metadata") continue;
      // Two of a kind would leave which one counts to the parser's order.
      if (seen)
        return HttpResponse::error(
            400, "bad_request",
            "the multipart body has two parts named '" + p.name + "'");
      seen = true;
      if (p.name == "image")
        up->image = p.body;
      else if (p.body.size() > kMaxMetadataBytes)
        return metadata_too_large();
      else
        meta_text = std::string(p.body);
    }
    if (!has_image)
      return HttpResponse::error(
          422, "unprocessable", "the multipart body has no part named 'image'");
  } else {
    up->image = req.body;
    meta_text = req.header("x-capture-metadata");
  }
  if (meta_text.size() > kMaxMetadataBytes) return metadata_too_large();
  if (!meta_text.empty()) {
    auto meta = http::parse_json_body(meta_text, &error);
    if (!meta)
      return HttpResponse::error(400, "invalid_json",
                                 "capture metadata: " + error);
    if (!meta->is_object())
      return HttpResponse::error(400, "bad_request",
                                 "capture metadata must be a JSON object");
    up->meta = *meta;
  }
  return std::nullopt;
}

// A metadata string field, or an error response when it has the wrong type
// or is too long.
std::optional<HttpResponse> string_field(const Json& meta, const char* key,
                                         std::size_t max, std::string* out) {
  auto it = meta.find(key);
  if (it == meta.end() || it->is_null()) return std::nullopt;
  if (!it->is_string() || it->get<std::string>().size() > max)
    return HttpResponse::error(422, "unprocessable",
                               std::string("metadata.") + key +
                                   " must be a string of at most " +
                                   std::to_string(max) + " characters");
  *out = it->get<std::string>();
  return std::nullopt;
}

HttpResponse replay_or_conflict(const db::Document& existing,
                                const Principal& who, const std::string& hash) {
  auto image = existing.blobs.find("image");
  bool same = documents::capture_from_json(existing.attrs).scout == who.name &&
              image != existing.blobs.end() && image->second == hash;
  if (!same)
    return HttpResponse::error(
        409, "conflict",
        "capture id " + existing.path.substr(10) +
            " already holds a different upload (another image or scout)");
  HttpResponse r = HttpResponse::json(201, to_json(existing));
  r.headers.emplace_back("Idempotent-Replay", "true");
  r.headers.emplace_back("Location", "/v1/docs" + existing.path);
  return r;
}

struct CaptureFields {
  std::string id, camera, site_hint, filename, taken;
  std::optional<GpsFix> gps;
};

std::optional<HttpResponse> read_fields(const Json& meta, CaptureFields* f) {
  for (auto [key, max, out] :
       {std::tuple{"capture_id", std::size_t{128}, &f->id},
        {"camera", 128, &f->camera},
        {"site_hint", 128, &f->site_hint},
        {"filename", 256, &f->filename},
        {"taken", 64, &f->taken}})
    if (auto bad = string_field(meta, key, max, out)) return bad;
  if (!f->taken.empty() && !parse_time_utc(f->taken))
    return HttpResponse::error(
        422, "unprocessable",
        "taken must be an RFC 3339 time (2026-11-21T13:05:00Z)");
  if (!f->id.empty()) db::validate_path("/captures/" + f->id);
  if (!f->camera.empty()) db::validate_path("/cameras/" + f->camera);
  if (f->id.find('/') != std::string::npos ||
      f->camera.find('/') != std::string::npos)
    return HttpResponse::error(
        400, "invalid_path", "capture_id and camera are single path segments");
  if (auto it = meta.find("gps"); it != meta.end() && !it->is_null()) {
    std::string error;
    f->gps = gps_from_json(*it, &error);
    if (!f->gps) return HttpResponse::error(422, "unprocessable", error);
    f->gps->source = "request";
  }
  return std::nullopt;
}

Json capture_attrs(const CaptureFields& f, const Principal& who,
                   const ImageProbe& probe, const ExifInfo& exif,
                   std::size_t bytes) {
  documents::Capture c;
  c.gps = f.gps ? f.gps : exif.gps;
  if (c.gps && !validate_gps(*c.gps).empty()) c.gps.reset();  // odd EXIF
  c.scout = who.name;
  c.received = format_time_utc(std::time(nullptr));
  c.format = probe.format;
  c.width = probe.width;
  c.height = probe.height;
  c.bytes = bytes;
  c.status = c.gps ? documents::CaptureStatus::kStored
                   : documents::CaptureStatus::kNeedsGps;
  c.status_reason = c.gps ? "" : "no GPS in the request or the EXIF";
  c.taken = f.taken.empty() ? exif.taken : f.taken;
  c.camera = f.camera;
  c.site_hint = f.site_hint;
  c.filename = f.filename;
  c.exif = {exif.focal_35mm, exif.focal_mm, exif.make, exif.model};
  return documents::to_json(c);
}

// The token's upload rate, then its new places (docs/api.md, "Limits"). A
// replay of a stored capture (checked before) counts against neither.
std::optional<HttpResponse> over_limits(ApiContext& ctx,
                                        const std::optional<GpsFix>& fix) {
  if (!ctx.limits) return std::nullopt;
  if (const int wait = ctx.limits->uploads.take(ctx.who.name); wait > 0) {
    ctx.metrics.refused("uploads");
    return uploads_refused(wait);
  }
  if (fix && validate_gps(*fix).empty())
    if (const int wait = ctx.limits->new_places.admit(ctx.store, ctx.who.name,
                                                      fix->lat, fix->lon);
        wait > 0) {
      ctx.metrics.refused("new_places");
      return new_places_refused(wait);
    }
  return std::nullopt;
}

}  // namespace

HttpResponse post_capture(ApiContext& ctx, const HttpRequest& req) {
  Upload up;
  if (auto bad = read_upload(req, &up)) return *bad;
  CaptureFields f;
  if (auto bad = read_fields(up.meta, &f)) return *bad;
  // Capture ids are "{name}.{id}": a name with a '.' (a token made before
  // names were checked) or none (a replayed session) would let one scout's
  // ids meet another's.
  if (std::string problem = token_name_problem(ctx.who.name); !problem.empty())
    return HttpResponse::error(403, "forbidden",
                               "the token's name '" + ctx.who.name +
                                   "' cannot own captures (" + problem +
                                   "): upload with a token named otherwise");
  if (!f.camera.empty()) {
    f.camera = capture_camera(ctx.store, ctx.who, f.camera);
    db::validate_path("/cameras/" + f.camera);  // the name made it longer
  }
  if (!f.id.empty()) {
    f.id = scoped_id(ctx.who, f.id);
    db::validate_path("/captures/" + f.id);  // the name made it longer
  }
  // A known capture id is checked before any work: a retry costs a hash.
  std::string path = "/captures/" + f.id;
  if (!f.id.empty())
    if (auto existing = ctx.store.get(path))
      return replay_or_conflict(*existing, ctx.who, util::sha256_hex(up.image));

  ImageProbe probe = probe_image(up.image);
  if (!probe.ok) return HttpResponse::error(422, "unprocessable", probe.error);
  ExifInfo exif = read_exif(up.image);
  if (auto refused = over_limits(ctx, f.gps ? f.gps : exif.gps))
    return *refused;

  // The blob first: the document may only refer to stored bytes. If the
  // document write then fails, the orphaned blob is collected by `db gc`.
  const std::string hash = ctx.store.put_blob(up.image);
  if (f.id.empty()) {  // named by its content: a re-upload is a replay
    f.id = scoped_id(ctx.who, hash.substr(0, 16));
    path = "/captures/" + f.id;
    if (auto existing = ctx.store.get(path))
      return replay_or_conflict(*existing, ctx.who, hash);
  }
  db::WriteOp op = db::WriteOp::put(
      path, "capture", capture_attrs(f, ctx.who, probe, exif, up.image.size()),
      0);
  op.blobs = db::BlobRefs{{"image", hash}};
  op.author = ctx.who.name;
  try {
    ctx.store.write(op);
  } catch (const db::ConflictError&) {  // a concurrent retry won the race
    if (auto existing = ctx.store.get(path))
      return replay_or_conflict(*existing, ctx.who, hash);
    throw;
  }
  ctx.metrics.add_upload_bytes(static_cast<std::int64_t>(up.image.size()));
  auto doc = ctx.store.get(path);
  HttpResponse r = HttpResponse::json(201, to_json(*doc));
  r.headers.emplace_back("Location", "/v1/docs" + path);
  return r;
}

HttpResponse withdraw_capture(ApiContext& ctx, const HttpRequest& /*req*/,
                              const std::string& id) {
  db::validate_path("/captures/" + id);
  const std::string path = "/captures/" + id;
  for (int attempt = 0; attempt < 5; ++attempt) {
    auto doc = ctx.store.get(path);
    if (!doc || doc->kind != "capture")
      return HttpResponse::error(404, "not_found", "no capture " + id);
    const documents::Capture capture = documents::capture_from_json(doc->attrs);
    if (ctx.who.role != Role::kAdmin &&
        !(ctx.who.role == Role::kScout && capture.scout == ctx.who.name))
      return HttpResponse::error(
          403, "forbidden",
          "only its own scout or an admin may withdraw " + id);
    if (capture.status == documents::CaptureStatus::kWithdrawn)
      return HttpResponse::json(200, to_json(*doc));
    db::WriteOp op = db::WriteOp::patch(
        path,
        documents::status_patch(documents::CaptureStatus::kWithdrawn,
                                "withdrawn by " + ctx.who.name),
        doc->version);
    op.author = ctx.who.name;
    try {
      ctx.store.write(op);
      return HttpResponse::json(200, to_json(*ctx.store.get(path)));
    } catch (const db::ConflictError&) {
      // The engine updated it meanwhile; read again and retry.
    }
  }
  return HttpResponse::error(503, "unavailable",
                             "capture " + id + " kept changing; retry");
}

}  // namespace arscout::ingest
