// The one mapping of the store's errors (db/errors.h), and of util::Error
// through them, to HTTP responses,
// for ingest's built-in routes and those other libraries add (the viewer's).
#pragma once

#include "arscout/db/errors.h"
#include "arscout/http/http_types.h"
#include "arscout/util/error.h"

namespace arscout::ingest {

// The one mapping of store errors to HTTP (docs/api.md), for the built-in
// routes and those other libraries add: invalid_path and invalid_json 400,
// not_found and unknown_blob 404, conflict 409, too_large 413,
// invalid_document and invalid_argument 422, unavailable 503, internal 500.
int http_status(db::ErrorCode code);
// That status with {"error": the code's name, "message": e.what()}, and
// "current_version" for a conflict.
http::HttpResponse error_response(const db::StoreError& e);
// The same for an error that is not the store's, through the store's code
// of its kind (db::code_of): a viewer route's kNotFound is a 404 too.
http::HttpResponse error_response(const util::Error& e);

}  // namespace arscout::ingest
