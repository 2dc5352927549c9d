#include "arscout/util/log_value.h"

namespace arscout::util {

std::string quoted_log_value(std::string_view text, std::size_t max_chars) {
  std::string out = "\"";
  const bool cut = text.size() > max_chars;
  for (char c : text.substr(0, max_chars)) {
    if (c == '"' || c == '\\') out += '\\';
    out += (c == '\n' || c == '\r') ? ' ' : c;
  }
  return out + (cut ? "...\"" : "\"");
}

}  // namespace arscout::util
