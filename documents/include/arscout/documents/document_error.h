// The error every reader of a stored form throws for a document that does
// not hold that form.
#pragma once

#include <stdexcept>

namespace arscout::documents {

// what(): the first bad field and what it should be, e.g. "fx must be a
// positive finite number (focal length in pixels)".
class DocumentError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

}  // namespace arscout::documents
