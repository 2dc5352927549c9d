// The error of everything that is not the document store: an argument or an
// input file out of its domain, something asked for that is not there, an
// output that cannot be written, a broken invariant. The store's own
// failures are db::StoreError (db/errors.h), thrown only in db/.
//
// Contract: every Error has a kind, named like the store's error code of
// the same meaning (db::code_of in db/errors.h gives that code). The CLI
// and the HTTP layer map an Error through that code, so it exits, answers
// and reads as the store's error of that code does: "arscout: error
// (not_found): ..." and exit code 3, or HTTP 404 {"error": "not_found"}.
// Like StoreError it is a std::runtime_error, so a catch of runtime_error
// takes both.
#pragma once

#include <stdexcept>
#include <string>

namespace arscout::util {

enum class ErrorKind {
  kInvalidArgument,  // an argument or input out of its domain
  kInvalidJson,      // text that should be JSON does not parse
  kNotFound,         // what was asked for is not there
  kConflict,         // a write lost to another (a server's HTTP 409)
  kUnavailable,      // cannot be done now: an output not writable, a race
  kInternal,         // a broken invariant or damaged stored data
};

class Error : public std::runtime_error {
 public:
  Error(ErrorKind kind, const std::string& message)
      : std::runtime_error(message), kind_(kind) {}
  ErrorKind kind() const { return kind_; }

 private:
  ErrorKind kind_;
};

}  // namespace arscout::util
