#include "cli_support.h"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <csignal>
#include <filesystem>
#include <iostream>

#include "arscout/db/errors.h"
#include "arscout/util/error.h"
#include "arscout/util/file.h"
#include "commands.h"

namespace arscout::cli {
namespace {

std::atomic<bool> g_stop{false};
int g_exit_code = kExitOk;

extern "C" void on_stop_signal(int) { g_stop = true; }

bool is_image_file(const std::filesystem::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  for (const char* e : {".jpg", ".jpeg", ".png", ".tif", ".tiff", ".bmp"})
    if (ext == e) return true;
  return false;
}

int exit_code_for(db::ErrorCode code) {
  switch (code) {
    case db::ErrorCode::kConflict:
      return kExitConflict;
    case db::ErrorCode::kNotFound:
    case db::ErrorCode::kUnknownBlob:
      return kExitNotFound;
    case db::ErrorCode::kUnavailable:
      return kExitUnavailable;
    case db::ErrorCode::kInternal:
      return kExitError;
    default:
      return kExitUsage;
  }
}

int reported(db::ErrorCode code, const char* what) {
  std::cerr << "arscout: error (" << db::to_string(code) << "): " << what
            << "\n";
  return exit_code_for(code);
}

int guarded(const std::function<int()>& body) {
  try {
    return body();
  } catch (const db::StoreError& e) {
    return reported(e.code(), e.what());
  } catch (const util::Error& e) {
    return reported(db::code_of(e.kind()), e.what());
  } catch (const std::exception& e) {
    std::cerr << "arscout: error: " << e.what() << "\n";
    return kExitError;
  }
}

}  // namespace

void run_command(const std::function<int()>& body) {
  g_exit_code = guarded(body);
}

std::vector<std::string> list_image_files(const std::string& dir) {
  std::vector<std::string> paths;
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    if (entry.is_regular_file() && is_image_file(entry.path()))
      paths.push_back(entry.path().string());
  std::sort(paths.begin(), paths.end());
  if (paths.empty())
    throw util::Error(
        util::ErrorKind::kInvalidArgument,
        "no images (.jpg, .jpeg, .png, .tif, .tiff, .bmp) in " + dir);
  return paths;
}

int last_exit_code() { return g_exit_code; }

db::Json parse_json_argument(const std::string& text, const std::string& what) {
  try {
    return db::Json::parse(text);
  } catch (const db::Json::parse_error& e) {
    throw util::Error(util::ErrorKind::kInvalidJson,
                      what + " is not valid JSON (at byte " +
                          std::to_string(e.byte) + "): " + e.what());
  }
}

std::string read_input_file(const std::string& path) {
  try {
    return util::read_file(path);
  } catch (const std::runtime_error& e) {
    throw util::Error(util::ErrorKind::kInvalidArgument, e.what());
  }
}

void write_output_file(const std::string& path, std::string_view bytes) {
  try {
    util::write_file_atomic(path, bytes);
  } catch (const std::runtime_error& e) {
    throw util::Error(util::ErrorKind::kUnavailable, e.what());
  }
}

void install_stop_handlers() {
  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);
}

bool stop_requested() { return g_stop; }

}  // namespace arscout::cli
