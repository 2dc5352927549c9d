// Fresh stores for tests, on either backend.
//
// PostgreSQL tests use the server started by the CTest fixture
// (tests/support/pg_fixture.sh), whose admin URL is in the file named by
// ARSCOUT_TEST_PG_URL_FILE (or directly in ARSCOUT_TEST_PG_URL). Each call
// creates a new database on it, so tests never see each other's data or
// notifications. When no server is available the test is skipped with a
// message, except under CI=true, where that is a failure.
#pragma once

#include <optional>
#include <string>

#include <gtest/gtest.h>

namespace arscout::testing {

bool in_ci();
// A new empty directory under the system temp dir.
std::string make_temp_dir(const std::string& tag);
// A URL for a new SQLite file in a new temp directory.
std::string fresh_sqlite_url();
// The fixture server's admin URL, or nullopt.
std::optional<std::string> postgres_admin_url();
// A URL for a new, empty database on the fixture server; nullopt when there
// is no server (why says why).
std::optional<std::string> fresh_postgres_url(std::string* why);
// "sqlite" -> fresh_sqlite_url(); "postgresql" -> fresh_postgres_url().
std::optional<std::string> fresh_store_url(const std::string& backend,
                                           std::string* why);

// Path of a helper executable built next to the test binaries.
std::string helper_path(const std::string& name);

// The real image data, ../shared/data beside the source tree (or
// $ARSCOUT_SHARED_DATA); nullopt when the folder `sub` is not there.
std::optional<std::string> shared_data(const std::string& sub);

}  // namespace arscout::testing

// Sets `url` to a fresh store of `backend`, or skips (fails under CI).
#define ARSCOUT_FRESH_STORE_OR_SKIP(url, backend)                      \
  do {                                                                 \
    std::string why_;                                                  \
    auto maybe_ = ::arscout::testing::fresh_store_url(backend, &why_); \
    if (!maybe_) {                                                     \
      if (::arscout::testing::in_ci()) FAIL() << why_;                 \
      GTEST_SKIP() << why_;                                            \
    }                                                                  \
    url = *maybe_;                                                     \
  } while (0)

// Sets `dir` to ../shared/data/`sub`, or skips (fails under CI, where the
// data is always present).
#define ARSCOUT_SHARED_DATA_OR_SKIP(dir, sub)                    \
  do {                                                           \
    auto maybe_ = ::arscout::testing::shared_data(sub);          \
    if (!maybe_) {                                               \
      std::string why_ =                                         \
          std::string("shared data folder '") + (sub) +          \
          "' not found (../shared/data or ARSCOUT_SHARED_DATA)"; \
      if (::arscout::testing::in_ci()) FAIL() << why_;           \
      GTEST_SKIP() << why_;                                      \
    }                                                            \
    dir = *maybe_;                                               \
  } while (0)
