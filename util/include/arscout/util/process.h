// Child processes whose output goes to a log file: the tests' tool
// processes and the benches' runs of arscout start them the same way; and
// a thread's scheduling priority.
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

// Lowers the calling thread's scheduling priority to `nice` (per thread on
// Linux, where a nice-5 thread gets about a third of a normal one's share
// of a contended core and a nice-10 one a tenth; elsewhere nothing): the
// engine's background lanes, the server's exports.
void set_thread_nice(int nice);

}  // namespace arscout::util
