// Running `arscout` to completion from an acceptance test.
#pragma once

#include <chrono>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tool_process.h"

namespace arscout::testing {

// Runs the CLI (ARSCOUT_CLI) with `args`, its output in `log`; fails the
// test, with the log, unless it exits 0 within ten minutes.
inline void run_cli(const std::vector<std::string>& args,
                    const std::string& log) {
  ToolProcess cli(ARSCOUT_CLI, args, log);
  const auto status = cli.wait_for(std::chrono::minutes(10));
  ASSERT_TRUE(status.has_value()) << "arscout timed out\n" << slurp(log);
  ASSERT_EQ(*status, 0) << describe_status(*status) << "\n" << slurp(log);
}

}  // namespace arscout::testing
