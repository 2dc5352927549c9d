// Whole-file reading and crash-safe whole-file writing: the one definition
// every library uses (docs/ARCHITECTURE.md).
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace arscout::util {

// The bytes of the file at `path`. Throws std::runtime_error
// "PATH: cannot read (REASON)" when it cannot be opened or read.
std::string read_file(const std::string& path);

// Replaces the file at `path` with `bytes` so that a reader or a crash sees
// either the old file or the whole new one, never a part: the bytes go to a
// new file beside it (same file system), are fsync'd, and the new file is
// renamed over `path`; the folder is then fsync'd so the rename itself
// survives a power cut. Safe between threads and processes writing the same
// path (each uses its own temporary name). The file gets `exact_mode`
// when given (0600 for a private key), else 0666 less the umask. Throws
// std::runtime_error "PATH: cannot write (REASON)"; on failure `path` is as
// it was and no temporary file is left.
void write_file_atomic(const std::string& path, std::string_view bytes,
                       std::optional<unsigned> exact_mode = std::nullopt);

}  // namespace arscout::util
