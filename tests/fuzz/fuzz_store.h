// A SQLite store in the temporary directory, for the targets that go
// through the API.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>
#include <system_error>

#include "arscout/db/store.h"

namespace arscout::fuzz {

class ScratchStore {
 public:
  ScratchStore()
      : dir_(std::filesystem::temp_directory_path() /
             ("arscout-fuzz-store-" + std::to_string(::getpid()))) {}
  ~ScratchStore() {
    store_.reset();
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
  ScratchStore(const ScratchStore&) = delete;
  ScratchStore& operator=(const ScratchStore&) = delete;

  // The store for the next input. It starts afresh every so many inputs,
  // so that a long run's change log does not fill the disk; *fresh says
  // when, for callers that keep state of their own in it.
  db::Store& next(bool* fresh) {
    *fresh = !store_ || ++uses_ > kUses;
    if (*fresh) {
      store_.reset();
      std::filesystem::remove_all(dir_);
      std::filesystem::create_directories(dir_);
      store_ = db::Store::open("sqlite:" + (dir_ / "fuzz.db").string());
      uses_ = 0;
    }
    return *store_;
  }

 private:
  static constexpr int kUses = 20000;
  std::filesystem::path dir_;
  std::unique_ptr<db::Store> store_;
  int uses_ = 0;
};

}  // namespace arscout::fuzz
