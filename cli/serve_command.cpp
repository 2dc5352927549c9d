// `arscout serve`: the HTTP API over a store.
#include <filesystem>
#include <iostream>
#include <thread>

#include "arscout/engine/service.h"
#include "arscout/http/self_signed.h"
#include "arscout/ingest/server.h"
#include "arscout/util/error.h"
#include "arscout/viewer/routes.h"
#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"
#include "engine_options.h"

namespace arscout::cli {
namespace {

struct ServeArgs {
  std::string db;
  std::string listen = "127.0.0.1:8080";
  std::string tls_cert;
  std::string tls_key;
  bool tls_self_signed = false;
  std::string tls_dir;
  std::size_t max_body_mb = 64;
  int io_threads = 2;
  int workers = 32;
  ingest::ServerOptions limits;  // the connection and stream caps
  bool with_engine = false;
  std::string web_root = viewer::default_web_root();
  engine::WorkerOptions engine;
  db::BlobCollectorOptions gc = default_gc_options();
};

// Caps against clients that hold what others need (docs/RELIABILITY.md,
// "Hostile clients"); 0 turns a cap off.
void add_limit_options(CLI::App* cmd, ingest::ServerOptions* limits) {
  cmd->add_option("--max-connections", limits->max_connections,
                  "open connections in all (503 beyond; kept under the "
                  "open-file limit)")
      ->capture_default_str();
  cmd->add_option("--max-connections-per-address",
                  limits->max_connections_per_address,
                  "open connections from one client address (503 beyond)")
      ->capture_default_str();
  cmd->add_option("--max-streams", limits->max_streams,
                  "open long-polls and WebSocket streams in all (429 beyond)")
      ->capture_default_str();
  cmd->add_option("--max-streams-per-token", limits->max_streams_per_token,
                  "open long-polls and WebSocket streams per token (429 "
                  "beyond)")
      ->capture_default_str();
  cmd->add_option("--min-body-rate", limits->min_body_rate,
                  "bytes per second a request body must keep to over every "
                  "10 s (408 and closed below)")
      ->capture_default_str();
  cmd->add_option("--max-bodies-per-token", limits->max_bodies_per_token,
                  "request bodies one token may have read at once (429 "
                  "beyond, from the header)")
      ->capture_default_str();
  // Per token and per address (docs/api.md, "Limits"): 429 beyond.
  const auto rate = [cmd](const char* name, double* value, const char* what) {
    cmd->add_option(name, *value, what)
        ->capture_default_str()
        ->check(CLI::NonNegativeNumber);
  };
  rate("--uploads-per-hour", &limits->uploads_per_hour,
       "captures one token may upload an hour on average (0: no limit)");
  rate("--upload-burst", &limits->upload_burst,
       "captures one token may upload at once before the hourly rate holds");
  rate("--new-places-per-hour", &limits->new_places_per_hour,
       "captures in new places (a fix farther than --new-place-m from every "
       "site and from the token's other new places) one token may upload an "
       "hour (0: no limit)");
  rate("--new-place-burst", &limits->new_place_burst,
       "new places one token may open at once");
  rate("--new-place-m", &limits->new_place_m,
       "metres from every site beyond which a capture is in a new place");
  rate("--auth-failures-per-hour", &limits->auth_failures_per_hour,
       "requests with an unknown, revoked or expired token one address may "
       "make an hour before its requests are refused (0: no limit)");
  rate("--auth-failure-burst", &limits->auth_failure_burst,
       "such requests one address may make at once");
}

// The web viewer's files; a missing three.js is worth a line at start-up,
// not a page that stays blank.
void mount_viewer(const std::string& web_root, ingest::ServerOptions* options) {
  if (web_root.empty()) return;
  namespace fs = std::filesystem;
  if (!fs::exists(fs::path(web_root) / "index.html")) {
    std::cerr << "arscout serve: no web viewer at " << web_root
              << " (index.html missing); serving the API only" << std::endl;
    return;
  }
  if (!fs::exists(fs::path(web_root) / "node_modules/three/build"))
    std::cerr << "arscout serve: three.js is not installed in " << web_root
              << "/node_modules (run: npm ci --prefix " << web_root
              << "); the viewer page will not draw" << std::endl;
  options->static_mounts = viewer::web_mounts(web_root);
}

// --tls-self-signed: the certificate kept for this machine's names (made
// on first use, remade when a name is new or it nears its end).
void use_self_signed(const ServeArgs& a, ingest::ServerOptions* options) {
  const std::vector<std::string> names = http::machine_names();
  const http::SelfSignedCertificate cert = http::ensure_self_signed(
      a.tls_dir.empty() ? http::default_tls_dir() : a.tls_dir, names);
  options->tls_cert = cert.cert_path;
  options->tls_key = cert.key_path;
  std::string list;
  for (const std::string& n : cert.names)
    list += (list.empty() ? "" : ", ") + n;
  std::cout << "TLS: " << (cert.created ? "made" : "reusing")
            << " self-signed certificate " << cert.cert_path << " for " << list
            << "\nTLS certificate SHA-256 fingerprint " << cert.fingerprint
            << std::endl;
}

// Where phones find the scout app when the server listens on every
// address (docs/scout-app.md).
void print_scout_addresses(const ingest::ServerOptions& options, int port,
                           bool tls) {
  if (options.host != "0.0.0.0" && options.host != "::") return;
  for (const std::string& name : http::machine_names()) {
    if (name == "localhost" || name == "127.0.0.1" || name == "::1") continue;
    const bool v6 = name.find(':') != std::string::npos;
    std::cout << "scout app at " << (tls ? "https://" : "http://")
              << (v6 ? "[" + name + "]" : name) << ":" << port << "/scout/"
              << std::endl;
  }
}

int serve(ServeArgs& a) {
  ingest::ServerOptions options;
  if (!split_listen(a.listen, &options.host, &options.port))
    throw util::Error(util::ErrorKind::kInvalidArgument,
                      "--listen must be HOST:PORT, not '" + a.listen + "'");
  options.tls_cert = a.tls_cert;
  options.tls_key = a.tls_key;
  if (a.tls_self_signed) use_self_signed(a, &options);
  options.max_body_bytes = a.max_body_mb << 20;
  options.io_threads = a.io_threads;
  options.worker_threads = a.workers;
  options.max_connections = a.limits.max_connections;
  options.max_connections_per_address = a.limits.max_connections_per_address;
  options.max_streams = a.limits.max_streams;
  options.max_streams_per_token = a.limits.max_streams_per_token;
  options.min_body_rate = a.limits.min_body_rate;
  options.max_bodies_per_token = a.limits.max_bodies_per_token;
  options.uploads_per_hour = a.limits.uploads_per_hour;
  options.upload_burst = a.limits.upload_burst;
  options.new_places_per_hour = a.limits.new_places_per_hour;
  options.new_place_burst = a.limits.new_place_burst;
  options.new_place_m = a.limits.new_place_m;
  options.auth_failures_per_hour = a.limits.auth_failures_per_hour;
  options.auth_failure_burst = a.limits.auth_failure_burst;
  if (a.with_engine) check_gc_grace(a.gc, a.engine);
  install_stop_handlers();
  auto store = db::Store::open(a.db);
  options.routes = viewer::viewer_routes(*store);
  mount_viewer(a.web_root, &options);
  std::unique_ptr<engine::EngineWorker> worker;
  if (a.with_engine) {
    log_worker_progress(&a.engine);
    worker = std::make_unique<engine::EngineWorker>(*store, a.engine);
    expose_worker(*worker, &options);
  }
  db::BlobCollector collector(*store, a.gc);
  expose_collector(collector, &options);
  ingest::Server server(*store, options);
  server.start();
  collector.start();
  std::cout << "arscout serving " << store->backend() << " store at "
            << (server.tls() ? "https://" : "http://") << options.host << ":"
            << server.port() << std::endl;
  print_scout_addresses(options, server.port(), server.tls());
  if (worker) worker->start();
  while (!stop_requested())
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  if (worker) worker->stop();
  server.stop();
  collector.stop();
  std::cout << "arscout server stopped" << std::endl;
  return kExitOk;
}

void add_serve_command(CLI::App& app) {
  static ServeArgs args;
  CLI::App* cmd = app.add_subcommand(
      "serve", "serve the HTTP API (docs/api.md) for scouts and planners");
  cmd->add_option("--db", args.db,
                  "database URL: sqlite:FILE or postgresql://...")
      ->required();
  cmd->add_option("--listen", args.listen,
                  "HOST:PORT to listen on (port 0: any)")
      ->capture_default_str();
  cmd->add_option("--tls-cert", args.tls_cert,
                  "PEM certificate chain: serve HTTPS");
  CLI::Option* key = cmd->add_option("--tls-key", args.tls_key,
                                     "PEM private key for --tls-cert");
  CLI::Option* self_signed = cmd->add_flag(
      "--tls-self-signed", args.tls_self_signed,
      "serve HTTPS with a self-signed certificate for this machine's names "
      "and addresses, made once and kept in --tls-dir; prints its SHA-256 "
      "fingerprint (phones need HTTPS for the scout app: docs/scout-app.md)");
  self_signed->excludes("--tls-cert")->excludes(key);
  cmd->add_option("--tls-dir", args.tls_dir,
                  "where --tls-self-signed keeps cert.pem and key.pem "
                  "(default $XDG_CONFIG_HOME/arscout/tls or "
                  "~/.config/arscout/tls)");
  cmd->add_option("--max-body-mb", args.max_body_mb,
                  "largest request body in MiB (413 beyond)")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  cmd->add_option("--io-threads", args.io_threads, "network threads")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  cmd->add_option("--workers", args.workers,
                  "handler threads (uploads, queries); long-polls and "
                  "WebSocket streams wait without one")
      ->capture_default_str()
      ->check(CLI::Range(1, 1024));
  add_limit_options(cmd, &args.limits);
  cmd->add_option("--web-root", args.web_root,
                  "folder of the web viewer served at / (\"\": none)")
      ->capture_default_str();
  cmd->add_flag("--with-engine", args.with_engine,
                "also run an engine worker in this process (docs/service.md)");
  add_engine_worker_options(cmd, &args.engine);
  add_gc_options(cmd, &args.gc);
  cmd->callback([] { run_command([] { return serve(args); }); });
}

const CommandRegistration serve_command_registration(20, add_serve_command);

}  // namespace
}  // namespace arscout::cli
