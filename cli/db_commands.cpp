// `arscout db ...`: operator commands over any store URL.
#include <iostream>
#include <thread>

#include "arscout/db/path.h"
#include "arscout/db/store.h"
#include "arscout/util/error.h"
#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"

namespace arscout::cli {
namespace {

using db::Json;

struct DbArgs {
  std::string url;
  std::string path;
  std::string json;
  std::string kind = "document";
  std::string pattern = "/**";
  std::string author;
  std::int64_t expect_version = -1;
  int depth = -1;
  std::int64_t since = 0;
  std::size_t limit = 1000;
  long long gc_min_age_s = 3600;
};

std::unique_ptr<db::Store> open_store(const DbArgs& a) {
  db::OpenOptions options;
  if (!a.author.empty()) options.default_author = a.author;
  return db::Store::open(a.url, options);
}

std::optional<std::int64_t> expected(const DbArgs& a) {
  if (a.expect_version < 0) return std::nullopt;
  return a.expect_version;
}

void print_result(const db::WriteResult& r) {
  std::cout
      << Json{{"path", r.path}, {"version", r.version}, {"seq", r.seq}}.dump()
      << std::endl;
}

CLI::App* add(CLI::App& parent, const std::string& name,
              const std::string& help, DbArgs& a) {
  CLI::App* cmd = parent.add_subcommand(name, help);
  cmd->add_option("url", a.url, "database URL: sqlite:FILE or postgresql://...")
      ->required();
  return cmd;
}

// Options every writing command takes.
void add_write_options(CLI::App& cmd, DbArgs& a) {
  cmd.add_option("--expect-version", a.expect_version,
                 "fail with a conflict unless the document is at this "
                 "version (0: must not exist)");
  cmd.add_option("--author", a.author, "writer identity to record");
}

void add_init(CLI::App& dbc, DbArgs& a) {
  auto* cmd = add(dbc, "init",
                  "create the store (or apply pending schema migrations)", a);
  cmd->callback([&a] {
    run_command([&] {
      auto store = open_store(a);
      auto versions = store->schema_versions();
      std::cout << Json{{"backend", store->backend()},
                        {"schema_version",
                         versions.empty() ? 0 : versions.back()},
                        {"last_seq", store->last_seq()}}
                       .dump()
                << std::endl;
      return kExitOk;
    });
  });
}

void add_put(CLI::App& dbc, DbArgs& a) {
  auto* cmd =
      add(dbc, "put", "write a document's attributes (a JSON object)", a);
  cmd->add_option("path", a.path, "document path, e.g. /sites/s-1")->required();
  cmd->add_option("json", a.json, "attributes, a JSON object")->required();
  cmd->add_option("--kind", a.kind, "document kind")->capture_default_str();
  add_write_options(*cmd, a);
  cmd->callback([&a] {
    run_command([&] {
      Json attrs = parse_json_argument(a.json, "the document's attributes");
      auto store = open_store(a);
      print_result(store->put(a.path, a.kind, attrs, expected(a)));
      return kExitOk;
    });
  });
}

void add_patch(CLI::App& dbc, DbArgs& a) {
  auto* cmd = add(dbc, "patch", "apply a JSON merge patch (RFC 7386)", a);
  cmd->add_option("path", a.path, "document path")->required();
  cmd->add_option("json", a.json, "merge patch, a JSON object")->required();
  add_write_options(*cmd, a);
  cmd->callback([&a] {
    run_command([&] {
      Json patch = parse_json_argument(a.json, "the merge patch");
      auto store = open_store(a);
      print_result(store->patch(a.path, patch, expected(a)));
      return kExitOk;
    });
  });
}

void add_rm(CLI::App& dbc, DbArgs& a) {
  auto* cmd = add(dbc, "rm", "delete a document (a tombstone in the log)", a);
  cmd->add_option("path", a.path, "document path")->required();
  add_write_options(*cmd, a);
  cmd->callback([&a] {
    run_command([&] {
      auto store = open_store(a);
      print_result(store->remove(a.path, expected(a)));
      return kExitOk;
    });
  });
}

void add_get(CLI::App& dbc, DbArgs& a) {
  auto* cmd = add(dbc, "get",
                  "print a document as JSON; with --depth, its subtree as one "
                  "JSON line per document",
                  a);
  cmd->add_option("path", a.path, "document path ('/' with --depth: all)")
      ->required();
  cmd->add_option("--depth", a.depth, "levels below path to include (>= 0)")
      ->check(CLI::NonNegativeNumber);
  cmd->callback([&a] {
    run_command([&] {
      auto store = open_store(a);
      if (a.depth >= 0) {
        for (const auto& d : store->get_subtree(a.path, a.depth))
          std::cout << to_json(d).dump() << "\n";
        std::cout.flush();
        return kExitOk;
      }
      auto doc = store->get(a.path);
      if (!doc)
        throw util::Error(util::ErrorKind::kNotFound,
                          "no document at " + a.path);
      std::cout << to_json(*doc).dump(2) << std::endl;
      return kExitOk;
    });
  });
}

void add_ls(CLI::App& dbc, DbArgs& a) {
  auto* cmd = add(dbc, "ls",
                  "list documents matching a path pattern ('*' = one "
                  "segment, trailing '**' = any depth): path, kind, version",
                  a);
  cmd->add_option("pattern", a.pattern, "path pattern, e.g. /captures/*")
      ->required();
  cmd->add_option("--limit", a.limit, "at most this many")
      ->capture_default_str();
  cmd->callback([&a] {
    run_command([&] {
      auto store = open_store(a);
      db::Query q;
      q.pattern = a.pattern;
      q.limit = a.limit;
      for (const auto& d : store->query(q))
        std::cout << d.path << "\t" << d.kind << "\tv" << d.version << "\n";
      std::cout.flush();
      return kExitOk;
    });
  });
}

void add_changes(CLI::App& dbc, DbArgs& a) {
  auto* cmd =
      add(dbc, "changes",
          "print change-log entries after --since, one JSON line each", a);
  cmd->add_option("--since", a.since, "print changes with seq > this")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--pattern", a.pattern, "only paths matching this pattern")
      ->capture_default_str();
  cmd->add_option("--limit", a.limit, "at most this many")
      ->capture_default_str();
  cmd->callback([&a] {
    run_command([&] {
      auto store = open_store(a);
      for (const auto& c : store->changes(a.since, a.pattern, a.limit))
        std::cout << to_json(c).dump() << "\n";
      std::cout.flush();
      return kExitOk;
    });
  });
}

void add_tail(CLI::App& dbc, DbArgs& a) {
  auto* cmd = add(dbc, "tail",
                  "follow the change feed live, one JSON line per change, "
                  "until interrupted",
                  a);
  cmd->add_option("--pattern", a.pattern, "only paths matching this pattern")
      ->capture_default_str();
  cmd->add_option("--since", a.since,
                  "start after this seq (default: the current end of the log)");
  cmd->callback([&a] {
    run_command([&] {
      install_stop_handlers();
      auto store = open_store(a);
      std::int64_t since = a.since > 0 ? a.since : store->last_seq();
      auto sub = store->subscribe(a.pattern, since, [](const db::Change& c) {
        std::cout << to_json(c).dump() << std::endl;
      });
      while (!stop_requested() && sub->error().empty())
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      sub->stop();
      if (!sub->error().empty()) throw std::runtime_error(sub->error());
      return kExitOk;
    });
  });
}

void add_gc(CLI::App& dbc, DbArgs& a) {
  auto* cmd =
      add(dbc, "gc",
          "delete blobs no document refers to (older than --min-age)", a);
  cmd->add_option("--min-age", a.gc_min_age_s,
                  "grace period in seconds for freshly stored blobs")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->callback([&a] {
    run_command([&] {
      auto store = open_store(a);
      std::size_t n =
          store->collect_garbage(std::chrono::seconds(a.gc_min_age_s));
      std::cout << Json{{"blobs_deleted", n}}.dump() << std::endl;
      return kExitOk;
    });
  });
}

void add_stats(CLI::App& dbc, DbArgs& a) {
  auto* cmd =
      add(dbc, "stats", "print counts of documents, blobs and the log", a);
  cmd->callback([&a] {
    run_command([&] {
      auto store = open_store(a);
      auto s = store->stats();
      std::cout << Json{{"backend", store->backend()},
                        {"documents", s.documents},
                        {"blobs", s.blobs},
                        {"blob_bytes", s.blob_bytes},
                        {"last_seq", s.last_seq}}
                       .dump()
                << std::endl;
      return kExitOk;
    });
  });
}

void add_db_commands(CLI::App& app) {
  static DbArgs args;  // CLI11 binds options to storage that outlives parsing
  CLI::App* dbc = app.add_subcommand(
      "db", "operate on a document store (sqlite:FILE or postgresql://...)");
  dbc->require_subcommand(1);
  add_init(*dbc, args);
  add_put(*dbc, args);
  add_patch(*dbc, args);
  add_rm(*dbc, args);
  add_get(*dbc, args);
  add_ls(*dbc, args);
  add_changes(*dbc, args);
  add_tail(*dbc, args);
  add_gc(*dbc, args);
  add_stats(*dbc, args);
}

const CommandRegistration db_commands_registration(10, add_db_commands);

}  // namespace
}  // namespace arscout::cli
