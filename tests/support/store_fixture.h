// A test on a fresh store of each backend (the test's parameter: "sqlite"
// or "postgresql"), skipped where the backend is missing (failed under CI).
#pragma once

#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "arscout/db/store.h"
#include "test_stores.h"

namespace arscout::testing {

class FreshStoreTest : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    ARSCOUT_FRESH_STORE_OR_SKIP(url_, GetParam());
    store_ = db::Store::open(url_);
  }

  std::string url_;
  std::unique_ptr<db::Store> store_;
};

}  // namespace arscout::testing
