// arscout: one executable, subcommands per concern (see --help).
#include <spdlog/cfg/helpers.h>
#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"

namespace {

// Logs go to stderr as "time level key=value ..." lines; quiet (warnings and
// errors only) unless --log-level or ARSCOUT_LOG asks for more.
void configure_logging(const std::string& level) {
  auto logger = spdlog::stderr_logger_mt("arscout");
  logger->set_pattern("%Y-%m-%dT%H:%M:%S.%e level=%l %v");
  spdlog::set_default_logger(logger);
  spdlog::set_level(spdlog::level::warn);
  if (const char* env = std::getenv("ARSCOUT_LOG"))
    spdlog::cfg::helpers::load_levels(env);
  if (!level.empty()) spdlog::set_level(spdlog::level::from_str(level));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "arscout: interactive, collaborative 3D reconstruction of urban sites.\n"
      "Scouts upload geotagged photos into a shared document store; the\n"
      "engine reconstructs each site incrementally and writes models back."};
  app.set_version_flag("--version", std::string("arscout ") + ARSCOUT_VERSION);
  app.require_subcommand(1);
  // Global options also after the command (`arscout serve --log-level
  // info`): the commands, made after this, pass what they do not know up.
  app.fallthrough();
  std::string log_level;
  app.add_option(
         "--log-level", log_level,
         "trace|debug|info|warn|error|off (default warn; env ARSCOUT_LOG)")
      ->check(
          CLI::IsMember({"trace", "debug", "info", "warn", "error", "off"}));
  app.parse_complete_callback([&] { configure_logging(log_level); });
  arscout::cli::add_registered_commands(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return arscout::cli::kExitUsage;
  }
  return arscout::cli::last_exit_code();
}
