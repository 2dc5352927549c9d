#include "sql_query.h"

#include "arscout/db/path.h"

namespace arscout::db::internal {
namespace {

// "?N" or "$N". (Appending, rather than "?" + to_string(n), also avoids a
// GCC 12 -O3 -Wrestrict false positive.)
std::string parameter_marker(Dialect dialect, std::size_t n) {
  std::string out(1, dialect == Dialect::kSqlite ? '?' : '$');
  out += std::to_string(n);
  return out;
}

// Appends parameters and returns their placeholders in the dialect's form.
class Builder {
 public:
  explicit Builder(Dialect dialect) : dialect_(dialect) {}

  // Typed, and constructed in place: a temporary SqlParam here trips GCC
  // 12's -Wmaybe-uninitialized on the variant's string member.
  template <typename T>
  std::string param(const T& value) {
    params_.emplace_back(std::in_place_type<T>, value);
    return parameter_marker(dialect_, params_.size());
  }
  void where(const std::string& condition) {
    sql_ += (first_ ? " WHERE " : " AND ") + condition;
    first_ = false;
  }
  void append(const std::string& text) { sql_ += text; }
  SqlStatement done() { return SqlStatement{sql_, params_}; }

 private:
  Dialect dialect_;
  std::string sql_;
  std::vector<SqlParam> params_;
  bool first_ = true;
};

// An attribute equality as an index-friendly condition, or "" when the value
// has no cheap SQL form (then only the exact C++ check applies).
std::string equality_condition(Builder& b, Dialect dialect,
                               const std::string& key, const Json& value) {
  if (dialect == Dialect::kPostgres) {
    // Containment is served by the GIN index on attrs.
    std::vector<std::string> parts;
    for (std::size_t start = 0;;) {
      std::size_t dot = key.find('.', start);
      parts.push_back(key.substr(start, dot - start));
      if (dot == std::string::npos) break;
      start = dot + 1;
    }
    Json nested = value;
    for (auto it = parts.rbegin(); it != parts.rend(); ++it) {
      Json wrapper = Json::object();
      wrapper[*it] = std::move(nested);
      nested = std::move(wrapper);
    }
    return "attrs @> " + b.param(nested.dump()) + "::jsonb";
  }
  std::string path = "'$." + key + "'";  // key validated: [A-Za-z0-9_.-]
  if (key.find('-') != std::string::npos) return "";
  std::string lhs = "json_extract(attrs, " + path + ")";
  if (value.is_string()) return lhs + " = " + b.param(value.get<std::string>());
  if (value.is_boolean())
    return lhs + " = " + b.param(std::int64_t{value.get<bool>() ? 1 : 0});
  if (value.is_number_integer())
    return lhs + " = " + b.param(value.get<std::int64_t>());
  if (value.is_number_float())
    return lhs + " = " + b.param(value.get<double>());
  return "";
}

}  // namespace

SqlStatement make_sql(Dialect dialect, std::string_view sql,
                      std::vector<SqlParam> params) {
  SqlStatement out;
  out.params = std::move(params);
  int n = 0;
  for (char c : sql) {
    if (c != '?') {
      out.sql.push_back(c);
      continue;
    }
    out.sql += parameter_marker(dialect, ++n);
  }
  return out;
}

const char* document_columns(Dialect dialect) {
  return dialect == Dialect::kSqlite
             ? "path, kind, attrs, blobs, version, seq, created_us, "
               "updated_us, author"
             : "path, kind, attrs::text, blobs::text, version, seq, "
               "created_us, updated_us, author";
}

SqlStatement document_page(Dialect dialect, const DocumentFilter& f) {
  Builder b(dialect);
  b.append(std::string("SELECT ") + document_columns(dialect) +
           " FROM documents");
  b.where("deleted = 0");
  b.where("path >= " + b.param(f.lo));
  b.where("path < " + b.param(f.hi));
  if (!f.after.empty()) b.where("path > " + b.param(f.after));
  if (f.min_depth) b.where("depth >= " + b.param(*f.min_depth));
  if (f.max_depth) b.where("depth <= " + b.param(*f.max_depth));
  if (f.box) {
    b.where("lat BETWEEN " + b.param(f.box->min_lat) + " AND " +
            b.param(f.box->max_lat));
    b.where("lon BETWEEN " + b.param(f.box->min_lon) + " AND " +
            b.param(f.box->max_lon));
  }
  for (const auto& [key, value] : f.equals) {
    std::string condition = equality_condition(b, dialect, key, value);
    if (!condition.empty()) b.where(condition);
  }
  b.append(" ORDER BY path LIMIT " +
           b.param(static_cast<std::int64_t>(f.limit)));
  return b.done();
}

DocumentFilter filter_for_query(const Query& query) {
  DocumentFilter f;
  f.lo = pattern_literal_prefix(query.pattern);
  f.hi = f.lo + "\x7f";  // every path character sorts below 0x7f
  auto segments = split_path(query.pattern);
  bool open_ended = !segments.empty() && segments.back() == "**";
  auto fixed = static_cast<std::int64_t>(segments.size());
  if (open_ended) {
    f.min_depth = fixed - 1;
  } else {
    f.min_depth = fixed;
    f.max_depth = fixed;
  }
  if (query.near) f.box = bounding_box(*query.near);
  f.equals = query.equals;
  return f;
}

DocumentFilter filter_for_subtree(const std::string& path, int max_depth) {
  DocumentFilter f;
  f.lo = path == "/" ? "/" : path;
  f.hi = f.lo + "\x7f";
  f.min_depth = static_cast<std::int64_t>(path_depth(path));
  f.max_depth = *f.min_depth + max_depth;
  return f;
}

SqlStatement change_page(Dialect dialect, std::int64_t after,
                         std::size_t limit) {
  Builder b(dialect);
  b.append("SELECT seq, path, op, version, kind, author, time_us FROM changes");
  b.where("seq > " + b.param(after));
  b.append(" ORDER BY seq LIMIT " + b.param(static_cast<std::int64_t>(limit)));
  return b.done();
}

}  // namespace arscout::db::internal
