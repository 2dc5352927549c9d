// Versioned schema files from schema/<backend>/NNNN_name.sql, compiled into
// the library so an installed binary can create and upgrade databases.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace arscout::db::internal {

struct Migration {
  int version;       // NNNN from the file name
  std::string name;  // the file name
  std::string_view sql;
};

// The migrations of a backend ("sqlite" or "postgresql"), by version.
std::vector<Migration> migrations_for(std::string_view backend);

}  // namespace arscout::db::internal
