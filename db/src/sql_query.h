// SQL text for the document and change-log reads, shared by both backends.
// The dialects differ only in placeholders (?N for SQLite, $N for
// PostgreSQL) and in how an attribute equality is pushed into an index.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "arscout/db/document.h"
#include "store_core.h"

namespace arscout::db::internal {

enum class Dialect { kSqlite, kPostgres };

// Raw bytes for a BLOB/bytea parameter (not copied until sent).
struct SqlBytes {
  std::string_view data;
};
struct SqlNull {};
using SqlParam =
    std::variant<std::int64_t, double, std::string, SqlBytes, SqlNull>;

struct SqlStatement {
  std::string sql;
  std::vector<SqlParam> params;
};

// A statement written with "?" placeholders, renumbered for the dialect.
SqlStatement make_sql(Dialect dialect, std::string_view sql,
                      std::vector<SqlParam> params = {});

// The selected columns, in the order decode functions expect them:
// path, kind, attrs, blobs, version, seq, created_us, updated_us, author.
const char* document_columns(Dialect dialect);

// Candidate rows for a page of documents: live, path in [lo, hi), after the
// `after` path, optionally within a depth range, a lat/lon box and attribute
// equalities (as index hints: the caller re-checks exactly), ordered by path.
struct DocumentFilter {
  std::string after;
  std::string lo;
  std::string hi;
  std::optional<std::int64_t> min_depth;
  std::optional<std::int64_t> max_depth;
  std::optional<LatLonBox> box;
  std::vector<std::pair<std::string, Json>> equals;
  std::size_t limit = 1000;
};
SqlStatement document_page(Dialect dialect, const DocumentFilter& filter);

// A DocumentFilter narrowing a Query (pattern prefix, depth, box, equalities).
DocumentFilter filter_for_query(const Query& query);
// A DocumentFilter for the subtree of path down to max_depth levels.
DocumentFilter filter_for_subtree(const std::string& path, int max_depth);

// Change-log rows with seq > after, in seq order, at most limit; columns:
// seq, path, op, version, kind, author, time_us.
SqlStatement change_page(Dialect dialect, std::int64_t after,
                         std::size_t limit);

}  // namespace arscout::db::internal
