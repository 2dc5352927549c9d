// Child processes whose output goes to a log file: the tests' tool
// processes and the benches' runs of arscout start them the same way.
#pragma once

#include <sys/types.h>

#include <string>
#include <vector>

namespace arscout::util {

// Starts argv[0] (a path, not searched in PATH) with `argv` and this
// process's environment, its stdout and stderr both to `log` (created with
// mode 0644; appended to when `append`, else truncated). Returns the
// child's pid, for the caller to wait for. Throws std::system_error naming
// argv[0] when it cannot be spawned, and std::invalid_argument for an
// empty argv.
pid_t spawn_logged(std::vector<std::string> argv, const std::string& log,
                   bool append);

}  // namespace arscout::util
