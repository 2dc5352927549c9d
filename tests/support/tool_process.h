// A helper executable (tests/support/store_tool) run as a process of its own,
// for tests that need several processes or one to kill.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <optional>
#include <string>
#include <vector>

namespace arscout::testing {

class ToolProcess {
 public:
  // Starts tool (an absolute path, or a helper beside the test binary) with
  // args; stdout and stderr append to log.
  ToolProcess(const std::string& tool, std::vector<std::string> args,
              const std::string& log);
  ~ToolProcess();  // kills it if it is still running
  ToolProcess(const ToolProcess&) = delete;
  ToolProcess& operator=(const ToolProcess&) = delete;

  // The wait status once it exits; nullopt if it runs past the timeout.
  std::optional<int> wait_for(std::chrono::milliseconds timeout);
  bool running();
  // SIGKILL unless it already ended; returns the wait status.
  int kill_now();
  // Sends a signal (e.g. SIGTERM) if it is still running.
  void signal(int signo);
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  std::optional<int> status_;
};

// "exit N", "signal N" or "status N" for a wait status.
std::string describe_status(int status);
// The whole content of a file ("" if it cannot be read).
std::string slurp(const std::string& path);
// What a shell command writes to its standard output; "" unless it exits
// with status 0.
std::string command_output(const std::string& command);

}  // namespace arscout::testing
