// Whole-file reading and atomic writing (util/file.h).
#include "arscout/util/file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <stdexcept>
#include <string>

namespace arscout::util {
namespace {

namespace fs = std::filesystem;

class FileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("arscout-file-test-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const {
    return (dir_ / name).string();
  }
  fs::path dir_;
};

TEST_F(FileTest, WritesReplacesAndReadsBack) {
  std::string bytes(100000, '\0');
  for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = char(i * 7);
  write_file_atomic(path("a.bin"), bytes);
  EXPECT_EQ(read_file(path("a.bin")), bytes);
  write_file_atomic(path("a.bin"), "short");
  EXPECT_EQ(read_file(path("a.bin")), "short");
  // Nothing left beside it.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), {}), 1);
}

TEST_F(FileTest, ExactModeForPrivateFiles) {
  write_file_atomic(path("key.pem"), "secret", 0600);
  struct stat st {};
  ASSERT_EQ(::stat(path("key.pem").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
}

TEST_F(FileTest, FailuresNameThePathAndKeepTheOldFile) {
  write_file_atomic(path("keep.txt"), "old");
  try {
    write_file_atomic(path("no/such/folder/x.txt"), "new");
    FAIL() << "wrote into a missing folder";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("x.txt: cannot write"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(read_file(path("keep.txt")), "old");
  try {
    read_file(path("missing.txt"));
    FAIL() << "read a missing file";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.txt: cannot read"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace arscout::util
