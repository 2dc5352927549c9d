// Small file systems of a test's own, to put a database on and then make
// fail under a running server. Both need root with CAP_SYS_ADMIN (CI runs
// as root); a test skips, saying why, where they cannot be had.
#pragma once

#include <string>

namespace arscout::testing {

// A tmpfs of the given size ("3m"), which can be grown or made read-only
// by remounting; Linux refuses a read-only remount while a file on it is
// open for writing.
class Tmpfs {
 public:
  explicit Tmpfs(const std::string& size);
  ~Tmpfs();
  Tmpfs(const Tmpfs&) = delete;
  Tmpfs& operator=(const Tmpfs&) = delete;

  bool mounted() const { return mounted_; }
  // Why not, when not mounted.
  const std::string& error() const { return error_; }
  const std::string& dir() const { return dir_; }
  bool remount(const std::string& size, bool read_only);

 private:
  std::string dir_, error_;
  bool mounted_ = false;
};

// An ext4 file system in an image file on a loop device, mounted with
// errors=remount-ro: what a server's disk does when the kernel sees it
// fail. fail() makes it do so (through ext4's trigger_fs_error), which
// turns it read-only under every process that has files open on it.
class Ext4Disk {
 public:
  explicit Ext4Disk(const std::string& size);
  ~Ext4Disk();
  Ext4Disk(const Ext4Disk&) = delete;
  Ext4Disk& operator=(const Ext4Disk&) = delete;

  bool mounted() const { return mounted_; }
  const std::string& error() const { return error_; }
  const std::string& dir() const { return dir_; }

  // Reports a file system error: ext4 aborts its journal and remounts
  // read-only. False (with error()) when that did not happen.
  bool fail();
  // What an operator does next: unmount, e2fsck -fy, mount read-write
  // again. Every process must have closed its files on it first.
  bool repair();

 private:
  bool mount_rw();

  std::string work_, dir_, image_, device_, error_;
  bool mounted_ = false;
};

}  // namespace arscout::testing
