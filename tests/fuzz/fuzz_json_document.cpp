// A document body as PUT and PATCH /v1/docs/{path} receive it: the API's
// JSON parser (parse_json_body), the body rules of the docs handler and the
// store's document validation, on a real SQLite store. docs_request is
// called as Api::handle calls it, so a refusal is a 4xx response or a
// db::StoreError (which Api answers with error_response); any other exception
// escapes and is a finding, as is a 5xx. A write that is accepted must read
// back as what was sent: the attributes of a PUT, the merge patch applied
// for a PATCH.
#include <optional>
#include <string>

#include "api_handlers.h"
#include "arscout/db/errors.h"
#include "arscout/db/store.h"
#include "fuzz_store.h"
#include "fuzz_support.h"
#include "metrics.h"

namespace {

namespace db = arscout::db;
namespace ingest = arscout::ingest;
namespace http = arscout::http;
using arscout::fuzz::check;
using Json = db::Json;

constexpr const char* kPath = "/fuzz/doc";
const Json kBase = {{"a", 1}, {"b", {{"c", {1, 2}}, {"d", "x"}}}, {"e", "y"}};

http::HttpResponse request(db::Store& store, const std::string& method,
                           const std::string& body) {
  static ingest::Metrics metrics;
  static const ingest::Principal admin{ingest::Role::kAdmin, "fuzz"};
  ingest::ApiContext ctx{store, metrics, admin};
  http::HttpRequest req;
  req.method = method;
  req.target = std::string("/v1/docs") + kPath;
  req.path = req.target;
  req.body = body;
  try {
    return ingest::docs_request(ctx, req, kPath);
  } catch (const db::StoreError& e) {
    return ingest::error_response(e);
  }
}

// The refusals a body alone can earn: malformed JSON (400), an unknown
// blob (404), too large (413), not a document (422).
void check_status(const http::HttpResponse& r, const char* what) {
  const int s = r.status;
  if (s == 200 || s == 201 || s == 400 || s == 404 || s == 413 || s == 422)
    return;
  std::fprintf(stderr, "%s answered %d: %s\n", what, s, r.body.c_str());
  arscout::fuzz::fail("a document write is answered 2xx or a client error");
}

Json stored(const http::HttpResponse& r) {
  Json doc = Json::parse(r.body);
  check(doc.value("path", "") == kPath, "the response is the document");
  return doc;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  static arscout::fuzz::ScratchStore scratch;
  bool fresh = false;
  db::Store& store = scratch.next(&fresh);
  const std::string body(arscout::fuzz::as_text(data, size));

  std::string error;
  const std::optional<Json> parsed = http::parse_json_body(body, &error);
  check(parsed.has_value() == error.empty(),
        "parse_json_body sets an error exactly when it fails");

  http::HttpResponse put = request(store, "PUT", body);
  check_status(put, "PUT");
  if (put.status < 300) {
    check(parsed.has_value(), "a PUT accepted parsable JSON");
    const Json doc = stored(put);
    check(doc["kind"] == parsed->at("kind"), "a PUT stores the kind sent");
    check(doc["attrs"] == parsed->value("attrs", Json::object()),
          "a PUT stores the attributes sent");
    check(doc["blobs"] == parsed->value("blobs", Json::object()),
          "a PUT stores the blob references sent");
  }

  http::HttpResponse base =
      request(store, "PUT", Json{{"kind", "base"}, {"attrs", kBase}}.dump());
  check(base.status == 200 || base.status == 201, "the base document is put");
  http::HttpResponse patch = request(store, "PATCH", body);
  check_status(patch, "PATCH");
  if (patch.status < 300) {
    check(parsed.has_value(), "a PATCH accepted parsable JSON");
    Json expected = kBase;
    expected.merge_patch(*parsed);
    const Json doc = stored(patch);
    check(doc["attrs"] == expected, "a PATCH stores the merge patch applied");
    check(doc["kind"] == "base", "a PATCH keeps the kind");
  }
  return 0;
}
