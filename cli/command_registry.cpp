#include "command_registry.h"

#include <algorithm>
#include <vector>

namespace arscout::cli {
namespace {

struct Entry {
  int order;
  CommandAdder adder;
};

// A function-local static: registrations run during static initialisation,
// in an unspecified order across files.
std::vector<Entry>& registry() {
  static std::vector<Entry> entries;
  return entries;
}

}  // namespace

CommandRegistration::CommandRegistration(int order, CommandAdder adder) {
  registry().push_back(Entry{order, adder});
}

void add_registered_commands(CLI::App& app) {
  std::vector<Entry> entries = registry();
  std::stable_sort(
      entries.begin(), entries.end(),
      [](const Entry& a, const Entry& b) { return a.order < b.order; });
  for (const Entry& e : entries) e.adder(app);
}

}  // namespace arscout::cli
