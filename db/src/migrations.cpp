#include "migrations.h"

#include <algorithm>
#include <cstdlib>

#include "schema_files.h"  // generated: kSchemaFiles[]

namespace arscout::db::internal {

std::vector<Migration> migrations_for(std::string_view backend) {
  std::vector<Migration> out;
  for (const SchemaFile& file : kSchemaFiles) {
    if (file.backend != backend) continue;
    out.push_back(Migration{std::atoi(std::string(file.name).c_str()),
                            std::string(file.name), file.sql});
  }
  std::sort(out.begin(), out.end(), [](const Migration& a, const Migration& b) {
    return a.version < b.version;
  });
  return out;
}

}  // namespace arscout::db::internal
