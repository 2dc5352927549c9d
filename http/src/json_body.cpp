// parse_json_body (json_body.h): a request body parsed in one pass, in
// time and memory linear in its size, with its nesting bounded.
//
// nlohmann's callback parser (Json::parse with a callback) looks through
// the whole parent container at every closing bracket for values the
// callback discarded, so 80,000 empty objects in one array took seconds
// and a few hundred kilobytes of keys most of a minute (docs/RELIABILITY.md,
// "Hostile clients, round two"). This builder is driven by the SAX parser,
// which only counts the depth and builds the value.
#include <vector>

#include "arscout/http/json_body.h"

namespace arscout::http {
namespace {

// Copying and serialising a JSON value recurse once per level of nesting,
// so some ten thousand '[' would overflow a handler thread's stack: deeper
// bodies are refused while they are parsed.
constexpr std::size_t kMaxDepth = 512;

class BoundedBuilder {
 public:
  bool null() { return add(nullptr); }
  bool boolean(bool value) { return add(value); }
  bool number_integer(Json::number_integer_t value) { return add(value); }
  bool number_unsigned(Json::number_unsigned_t value) { return add(value); }
  bool number_float(Json::number_float_t value, const Json::string_t&) {
    return add(value);
  }
  bool string(Json::string_t& value) { return add(std::move(value)); }
  bool binary(Json::binary_t& value) {
    return add(Json::binary(std::move(value)));
  }
  bool start_object(std::size_t) { return open(Json::object()); }
  bool start_array(std::size_t) { return open(Json::array()); }
  bool key(Json::string_t& name) {
    key_ = std::move(name);
    return true;
  }
  bool end_object() { return close(); }
  bool end_array() { return close(); }
  bool parse_error(std::size_t byte, const std::string&,
                   const Json::exception& e) {
    // 406: a number beyond a double's range, which the lexer reads whole.
    error_ = e.id == 406 ? std::string("unreadable JSON: ") + e.what()
                         : "malformed JSON at byte " + std::to_string(byte) +
                               ": " + e.what();
    return false;
  }

  Json& root() { return root_; }
  const std::string& error() const { return error_; }

 private:
  // Where the next value goes: the root, the open array's end, or the open
  // object's member under the last key (the last of equal keys wins, as
  // Json::parse has it).
  Json* place(Json value) {
    if (open_.empty()) {
      root_ = std::move(value);
      return &root_;
    }
    Json& parent = *open_.back();
    if (parent.is_array()) {
      parent.push_back(std::move(value));
      return &parent.back();
    }
    Json& member = parent[key_];
    member = std::move(value);
    return &member;
  }
  bool add(Json value) {
    place(std::move(value));
    return true;
  }
  // A container's address stays valid while it is open: only the innermost
  // open container grows, and an object's members never move.
  bool open(Json container) {
    if (open_.size() >= kMaxDepth) {
      error_ =
          "JSON nested deeper than " + std::to_string(kMaxDepth) + " levels";
      return false;
    }
    open_.push_back(place(std::move(container)));
    return true;
  }
  bool close() {
    open_.pop_back();
    return true;
  }

  Json root_;
  std::vector<Json*> open_;
  std::string key_;
  std::string error_;
};

}  // namespace

std::optional<Json> parse_json_body(const std::string& text,
                                    std::string* error) {
  BoundedBuilder builder;
  if (Json::sax_parse(text, &builder)) return std::move(builder.root());
  *error = builder.error().empty() ? "malformed JSON" : builder.error();
  return std::nullopt;
}

}  // namespace arscout::http
