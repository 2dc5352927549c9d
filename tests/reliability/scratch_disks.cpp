#include "scratch_disks.h"

#include <fcntl.h>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "test_stores.h"

namespace arscout::testing {
namespace {

// Runs a shell command; its exit status, and what it printed in `output`.
int run(const std::string& command, std::string* output = nullptr) {
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return -1;
  std::string text;
  std::array<char, 512> chunk{};
  size_t n;
  while ((n = std::fread(chunk.data(), 1, chunk.size(), pipe)) > 0)
    text.append(chunk.data(), n);
  const int status = ::pclose(pipe);
  if (output) *output = text;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Whether creating a file in `dir` fails as on a read-only file system.
// statvfs() does not tell: on recent kernels (6.18 here) ext4's emergency
// read-only state leaves the mount flags as they were.
bool refuses_writes(const std::string& dir) {
  const std::string probe = dir + "/.write-probe";
  const int fd = ::open(probe.c_str(), O_CREAT | O_WRONLY, 0600);
  if (fd >= 0) {
    ::close(fd);
    ::unlink(probe.c_str());
    return false;
  }
  return errno == EROFS;
}

}  // namespace

Tmpfs::Tmpfs(const std::string& size) : dir_(make_temp_dir("tmpfs")) {
  mounted_ =
      ::mount("tmpfs", dir_.c_str(), "tmpfs", 0, ("size=" + size).c_str()) == 0;
  if (!mounted_)
    error_ = std::string(
                 "cannot mount a tmpfs (needs root with "
                 "CAP_SYS_ADMIN): ") +
             std::strerror(errno);
}

Tmpfs::~Tmpfs() {
  if (mounted_) ::umount2(dir_.c_str(), MNT_DETACH);
}

bool Tmpfs::remount(const std::string& size, bool read_only) {
  return ::mount("tmpfs", dir_.c_str(), "tmpfs",
                 MS_REMOUNT | (read_only ? MS_RDONLY : 0),
                 ("size=" + size).c_str()) == 0;
}

Ext4Disk::Ext4Disk(const std::string& size) : work_(make_temp_dir("ext4")) {
  image_ = work_ + "/disk.img";
  dir_ = work_ + "/mnt";
  std::string out;
  if (run("mkdir -p '" + dir_ + "' && truncate -s " + size + " '" + image_ +
              "' && mkfs.ext4 -q '" + image_ + "'",
          &out) != 0) {
    error_ = "cannot make an ext4 image: " + out;
    return;
  }
  if (run("losetup --find --show '" + image_ + "'", &out) != 0) {
    error_ = "no loop device (needs root and /dev/loop-control): " + out;
    return;
  }
  device_ = out.substr(0, out.find('\n'));
  // A loop device keeps a read-only flag set by an earlier user.
  run("blockdev --setrw " + device_);
  mount_rw();
}

Ext4Disk::~Ext4Disk() {
  if (mounted_) ::umount2(dir_.c_str(), MNT_DETACH);
  if (!device_.empty()) run("losetup -d " + device_);
}

bool Ext4Disk::mount_rw() {
  mounted_ = ::mount(device_.c_str(), dir_.c_str(), "ext4", 0,
                     "errors=remount-ro") == 0;
  if (!mounted_)
    error_ = "cannot mount " + device_ + ": " + std::strerror(errno);
  return mounted_;
}

bool Ext4Disk::fail() {
  const std::string trigger = "/sys/fs/ext4/" +
                              device_.substr(device_.rfind('/') + 1) +
                              "/trigger_fs_error";
  std::ofstream(trigger) << "arscout fault test\n";
  if (!refuses_writes(dir_)) {
    error_ = "writing " + trigger + " did not turn the disk read-only";
    return false;
  }
  return true;
}

bool Ext4Disk::repair() {
  if (::umount(dir_.c_str()) != 0) {
    error_ = std::string("cannot unmount: ") + std::strerror(errno);
    return false;
  }
  mounted_ = false;
  std::string out;
  // 0: clean, 1: errors corrected; anything more is a damaged file system.
  const int rc = run("e2fsck -fy " + device_, &out);
  if (rc > 1) {
    error_ = "e2fsck exit " + std::to_string(rc) + ": " + out;
    return false;
  }
  return mount_rw();
}

}  // namespace arscout::testing
