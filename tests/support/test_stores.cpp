#include "test_stores.h"

#include <libpq-fe.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <random>
#include <vector>

// Read by LeakSanitizer in the -DARSCOUT_SANITIZE=ON build (ignored
// otherwise). libpqxx 6.4 leaks the PGresult of a statement that fails on a
// broken connection (PostgresStore.RecoversFromKilledConnections... shows
// it); the allocation is libpq's, made inside libpqxx, not arscout's.
extern "C" const char* __lsan_default_suppressions() {
  return "leak:libpqxx-6.4.so\n";
}

namespace arscout::testing {
namespace {

std::string random_suffix() {
  static std::atomic<int> counter{0};
  std::random_device rd;
  return std::to_string(getpid()) + "_" + std::to_string(counter++) + "_" +
         std::to_string(rd() % 100000);
}

// The temp directories a test program made, removed when it exits after
// its tests passed: a suite run leaves /tmp as it found it (stores of
// hundreds of megabytes each added up to tens of gigabytes), while a failed
// test's directories stay behind as evidence. Helper processes run no tests
// and keep theirs for the test that spawned them.
class TempDirs {
 public:
  void add(const std::filesystem::path& dir) {
    std::lock_guard lock(mutex_);
    dirs_.push_back(dir);
  }
  ~TempDirs() {
    const ::testing::UnitTest& run = *::testing::UnitTest::GetInstance();
    if (run.test_to_run_count() == 0 || !run.Passed()) return;
    for (const std::filesystem::path& dir : dirs_) {
      std::error_code ignored;  // a mount point left busy stays; no matter
      std::filesystem::remove_all(dir, ignored);
    }
  }

 private:
  std::mutex mutex_;
  std::vector<std::filesystem::path> dirs_;
};

TempDirs& temp_dirs() {
  static TempDirs dirs;
  return dirs;
}

}  // namespace

bool in_ci() {
  const char* ci = std::getenv("CI");
  return ci != nullptr && std::string(ci) == "true";
}

std::string make_temp_dir(const std::string& tag) {
  auto dir = std::filesystem::temp_directory_path() /
             ("arscout-" + tag + "-" + random_suffix());
  std::filesystem::create_directories(dir);
  temp_dirs().add(dir);
  return dir.string();
}

std::string fresh_sqlite_url() {
  return "sqlite:" + make_temp_dir("sqlite") + "/store.db";
}

std::optional<std::string> postgres_admin_url() {
  if (const char* url = std::getenv("ARSCOUT_TEST_PG_URL")) return url;
  const char* file = std::getenv("ARSCOUT_TEST_PG_URL_FILE");
  if (file == nullptr) return std::nullopt;
  std::ifstream in(file);
  std::string url;
  if (!(in >> url) || url.empty()) return std::nullopt;
  return url;
}

std::optional<std::string> fresh_postgres_url(std::string* why) {
  auto admin = postgres_admin_url();
  if (!admin) {
    *why =
        "no PostgreSQL test server (run through ctest, which starts one, or "
        "set ARSCOUT_TEST_PG_URL)";
    return std::nullopt;
  }
  std::string name = "t_" + random_suffix();
  PGconn* conn = PQconnectdb(admin->c_str());
  if (PQstatus(conn) != CONNECTION_OK) {
    *why = "cannot reach the PostgreSQL test server at " + *admin + ": " +
           PQerrorMessage(conn);
    PQfinish(conn);
    return std::nullopt;
  }
  PGresult* res = PQexec(conn, ("CREATE DATABASE " + name).c_str());
  bool ok = PQresultStatus(res) == PGRES_COMMAND_OK;
  if (!ok)
    *why = std::string("CREATE DATABASE failed: ") + PQerrorMessage(conn);
  PQclear(res);
  PQfinish(conn);
  if (!ok) return std::nullopt;
  auto slash = admin->rfind('/');
  return admin->substr(0, slash + 1) + name;
}

std::optional<std::string> fresh_store_url(const std::string& backend,
                                           std::string* why) {
  if (backend == "sqlite") return fresh_sqlite_url();
  return fresh_postgres_url(why);
}

std::optional<std::string> shared_data(const std::string& sub) {
  std::filesystem::path root;
  if (const char* env = std::getenv("ARSCOUT_SHARED_DATA")) {
    root = env;
  } else {
    root = std::filesystem::path(ARSCOUT_SOURCE_DIR).parent_path() / "shared" /
           "data";
  }
  auto dir = root / sub;
  if (!std::filesystem::is_directory(dir)) return std::nullopt;
  return dir.string();
}

std::string helper_path(const std::string& name) {
  std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe");
  return (self.parent_path() / name).string();
}

}  // namespace arscout::testing
