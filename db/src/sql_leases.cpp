// Leases over SQL (Store::claim_leases and friends). Each call is one write
// transaction. Times come from the database (clock_timestamp() on
// PostgreSQL, julianday('now') on SQLite), never from the caller, so that
// workers whose clocks disagree still agree on who holds what.
#include <algorithm>

#include "sql_store.h"

namespace arscout::db::internal {
namespace {

struct LeaseSql {
  const char* now;      // the current time, in the column's type
  const char* expires;  // now plus one double parameter, in seconds
  const char* remaining_ms;
  const char* skip_locked;  // appended to the claim's SELECT
  const char* wait_locked;  // the same, waiting for the lock
};

LeaseSql lease_sql(Dialect dialect) {
  if (dialect == Dialect::kPostgres)
    return {"clock_timestamp()", "clock_timestamp() + make_interval(secs => ?)",
            "COALESCE(CAST(ROUND(EXTRACT(EPOCH FROM (expires_at - "
            "clock_timestamp())) * 1000) AS bigint), 0)",
            " FOR UPDATE SKIP LOCKED", " FOR UPDATE"};
  return {"((julianday('now') - 2440587.5) * 86400.0)",
          "((julianday('now') - 2440587.5) * 86400.0 + ?)",
          "COALESCE(CAST(ROUND((expires_at - (julianday('now') - 2440587.5) * "
          "86400.0) * 1000) AS INTEGER), 0)",
          "", ""};
}

double seconds(std::chrono::milliseconds ttl) {
  if (ttl.count() <= 0)
    throw StoreError(ErrorCode::kInvalidArgument,
                     "a lease needs a positive time to live");
  return static_cast<double>(ttl.count()) / 1000.0;
}

void check_holder(const std::string& holder) {
  if (holder.empty())
    throw StoreError(ErrorCode::kInvalidArgument, "a lease needs a holder");
}

}  // namespace

std::vector<std::string> SqlStore::claim_leases(
    const std::vector<std::string>& names, const std::string& holder,
    std::chrono::milliseconds ttl, std::size_t max_new) {
  check_holder(holder);
  const double ttl_s = seconds(ttl);
  const LeaseSql q = lease_sql(dialect_);
  // Sorted, so that two claimers lock rows in the same order.
  std::vector<std::string> sorted = names;
  std::sort(sorted.begin(), sorted.end());
  sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
  std::vector<std::string> held;
  with_write([&](SqlSession& s) {
    held.clear();
    std::size_t taken = 0;
    for (const std::string& name : sorted) {
      s.execute(make_sql(
          dialect_,
          "INSERT INTO leases (name) VALUES (?) ON CONFLICT (name) DO NOTHING",
          {name}));
      const std::string select =
          std::string(
              "SELECT holder, CASE WHEN expires_at IS NULL OR "
              "expires_at <= ") +
          q.now + " THEN 1 ELSE 0 END FROM leases WHERE name = ?";
      auto rows = s.query(make_sql(dialect_, select + q.skip_locked, {name}));
      if (rows.empty()) {
        // Another worker is looking at it now. Ours stays ours (it may only
        // take an expired one), so for our own we wait for its turn to end.
        auto peek = s.query(make_sql(dialect_, select, {name}));
        if (peek.empty() || peek[0][0].value_or("") != holder) continue;
        rows = s.query(make_sql(dialect_, select + q.wait_locked, {name}));
        if (rows.empty()) continue;
      }
      const std::string current = rows[0][0].value_or("");
      const bool expired = to_int(rows[0][1]) != 0;
      if (current == holder) {
        s.execute(make_sql(dialect_,
                           std::string("UPDATE leases SET expires_at = ") +
                               q.expires + " WHERE name = ?",
                           {ttl_s, name}));
      } else if ((current.empty() || expired) && taken < max_new) {
        s.execute(make_sql(dialect_,
                           std::string("UPDATE leases SET holder = ?, "
                                       "expires_at = ") +
                               q.expires +
                               ", generation = generation + 1 WHERE name = ?",
                           {holder, ttl_s, name}));
        ++taken;
      } else {
        continue;
      }
      held.push_back(name);
    }
  });
  return held;
}

std::vector<std::string> SqlStore::renew_leases(const std::string& holder,
                                                std::chrono::milliseconds ttl) {
  check_holder(holder);
  const double ttl_s = seconds(ttl);
  std::vector<std::string> held;
  with_write([&](SqlSession& s) {
    held.clear();
    s.execute(make_sql(dialect_,
                       std::string("UPDATE leases SET expires_at = ") +
                           lease_sql(dialect_).expires + " WHERE holder = ?",
                       {ttl_s, holder}));
    for (const SqlRow& row : s.query(make_sql(
             dialect_, "SELECT name FROM leases WHERE holder = ? ORDER BY name",
             {holder})))
      held.push_back(row[0].value_or(""));
  });
  return held;
}

void SqlStore::release_leases(const std::string& holder,
                              const std::vector<std::string>& names) {
  check_holder(holder);
  const char* free_them =
      "UPDATE leases SET holder = NULL, expires_at = NULL WHERE holder = ?";
  with_write([&](SqlSession& s) {
    if (names.empty()) {
      s.execute(make_sql(dialect_, free_them, {holder}));
      return;
    }
    for (const std::string& name : names)
      s.execute(make_sql(dialect_, std::string(free_them) + " AND name = ?",
                         {holder, name}));
  });
}

std::vector<Lease> SqlStore::leases(std::string_view prefix) {
  std::vector<Lease> out;
  with_read([&](SqlSession& s) {
    out.clear();
    for (const SqlRow& row : s.query(make_sql(
             dialect_,
             std::string("SELECT name, holder, ") +
                 lease_sql(dialect_).remaining_ms +
                 ", generation FROM leases WHERE substr(name, 1, ?) = ? "
                 "ORDER BY name",
             {static_cast<std::int64_t>(prefix.size()),
              std::string(prefix)}))) {
      Lease lease;
      lease.name = row[0].value_or("");
      lease.holder = row[1].value_or("");
      lease.remaining = std::chrono::milliseconds(to_int(row[2]));
      lease.generation = to_int(row[3]);
      out.push_back(std::move(lease));
    }
  });
  return out;
}

}  // namespace arscout::db::internal
