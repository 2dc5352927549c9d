#include "arscout/ingest/store_errors.h"

namespace arscout::ingest {

int http_status(db::ErrorCode code) {
  using db::ErrorCode;
  switch (code) {
    case ErrorCode::kInvalidPath:
    case ErrorCode::kInvalidJson:
      return 400;
    case ErrorCode::kNotFound:
    case ErrorCode::kUnknownBlob:
      return 404;
    case ErrorCode::kConflict:
      return 409;
    case ErrorCode::kTooLarge:
      return 413;
    case ErrorCode::kInvalidDocument:
    case ErrorCode::kInvalidArgument:
      return 422;
    case ErrorCode::kUnavailable:
      return 503;
    case ErrorCode::kInternal:
      return 500;
  }
  return 500;
}

http::HttpResponse error_response(const db::StoreError& e) {
  http::Json extra = http::Json::object();
  // A client resolving a conflict needs the version it lost to.
  if (auto* c = dynamic_cast<const db::ConflictError*>(&e))
    extra["current_version"] = c->current_version();
  return http::HttpResponse::error(http_status(e.code()),
                                   db::to_string(e.code()), e.what(), extra);
}

http::HttpResponse error_response(const util::Error& e) {
  const db::ErrorCode code = db::code_of(e.kind());
  return http::HttpResponse::error(http_status(code), db::to_string(code),
                                   e.what());
}

}  // namespace arscout::ingest
