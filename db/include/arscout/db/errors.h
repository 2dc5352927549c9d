// Typed errors of the document store.
//
// Every failure the store reports is a StoreError carrying an ErrorCode, so
// callers (the CLI, the HTTP layer) can map it to an exit code or a status
// without parsing messages. Messages name what was wrong and where.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

#include "arscout/util/error.h"

namespace arscout::db {

enum class ErrorCode {
  kInvalidPath,      // a document path or pattern breaks the path rules
  kInvalidDocument,  // attributes not a JSON object, bad kind, bad blob name
  kInvalidJson,      // text that should be JSON does not parse
  kTooLarge,         // attributes or another input over its size limit
  kConflict,         // expected version does not match the stored one
  kNotFound,         // no live document at the path
  kUnknownBlob,      // a referenced or requested blob hash is not stored
  kInvalidArgument,  // any other argument out of its domain
  kUnavailable,      // the database cannot be opened or reached
  kInternal,         // a broken invariant or unexpected database error
};

// Stable lower-case name of a code, e.g. "conflict" (used in JSON errors).
const char* to_string(ErrorCode code);

// The code of the same meaning as an error kind of the rest of arscout
// (util/error.h), through which the CLI and the HTTP layer map both.
ErrorCode code_of(util::ErrorKind kind);

class StoreError : public std::runtime_error {
 public:
  StoreError(ErrorCode code, const std::string& message)
      : std::runtime_error(message), code_(code) {}
  ErrorCode code() const { return code_; }

 private:
  ErrorCode code_;
};

// A write whose expected version differs from the stored one. A version of 0
// means "no live document".
class ConflictError : public StoreError {
 public:
  ConflictError(const std::string& path, std::int64_t expected,
                std::int64_t current);
  const std::string& path() const { return path_; }
  std::int64_t expected_version() const { return expected_; }
  std::int64_t current_version() const { return current_; }

 private:
  std::string path_;
  std::int64_t expected_;
  std::int64_t current_;
};

}  // namespace arscout::db
