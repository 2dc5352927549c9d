// One value of a structured log line ("time level=info key=value ..."), the
// format the server and the engine share on stderr.
#pragma once

#include <string>
#include <string_view>

namespace arscout::util {

// `text` in double quotes, with quotes and backslashes escaped and line
// breaks made spaces, so that a value from a client or a message stays one
// record of one line. At most `max_chars` of it (then "...").
std::string quoted_log_value(std::string_view text,
                             std::size_t max_chars = 1024);

}  // namespace arscout::util
