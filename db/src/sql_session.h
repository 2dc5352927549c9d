// The narrow interface SqlStore needs from a database connection: run one
// statement with parameters, or a script. Values come back as text (numbers
// in decimal) or raw bytes (BLOB/bytea); NULL as nullopt.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "sql_query.h"

namespace arscout::db::internal {

using SqlValue = std::optional<std::string>;
using SqlRow = std::vector<SqlValue>;

class SqlSession {
 public:
  virtual ~SqlSession() = default;
  virtual std::vector<SqlRow> query(const SqlStatement& statement) = 0;
  // Returns the number of rows changed.
  virtual std::int64_t execute(const SqlStatement& statement) = 0;
  // Several statements without parameters (schema files).
  virtual void execute_script(std::string_view sql) = 0;
};

std::int64_t to_int(const SqlValue& value);

}  // namespace arscout::db::internal
