#include "arscout/db/errors.h"

namespace arscout::db {

const char* to_string(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidPath:
      return "invalid_path";
    case ErrorCode::kInvalidDocument:
      return "invalid_document";
    case ErrorCode::kInvalidJson:
      return "invalid_json";
    case ErrorCode::kTooLarge:
      return "too_large";
    case ErrorCode::kConflict:
      return "conflict";
    case ErrorCode::kNotFound:
      return "not_found";
    case ErrorCode::kUnknownBlob:
      return "unknown_blob";
    case ErrorCode::kInvalidArgument:
      return "invalid_argument";
    case ErrorCode::kUnavailable:
      return "unavailable";
    case ErrorCode::kInternal:
      return "internal";
  }
  return "internal";
}

ErrorCode code_of(util::ErrorKind kind) {
  switch (kind) {
    case util::ErrorKind::kInvalidArgument:
      return ErrorCode::kInvalidArgument;
    case util::ErrorKind::kInvalidJson:
      return ErrorCode::kInvalidJson;
    case util::ErrorKind::kNotFound:
      return ErrorCode::kNotFound;
    case util::ErrorKind::kConflict:
      return ErrorCode::kConflict;
    case util::ErrorKind::kUnavailable:
      return ErrorCode::kUnavailable;
    case util::ErrorKind::kInternal:
      break;
  }
  return ErrorCode::kInternal;
}

namespace {
std::string describe_version(std::int64_t v) {
  return v == 0 ? std::string("absent") : "version " + std::to_string(v);
}
}  // namespace

ConflictError::ConflictError(const std::string& path, std::int64_t expected,
                             std::int64_t current)
    : StoreError(ErrorCode::kConflict,
                 "version conflict at " + path + ": expected " +
                     describe_version(expected) + ", current is " +
                     describe_version(current)),
      path_(path),
      expected_(expected),
      current_(current) {}

}  // namespace arscout::db
