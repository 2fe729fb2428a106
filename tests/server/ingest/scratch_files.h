// Scratch files for tests that write small USD scenes and run the reader:
// one directory per test process, removed when the process exits.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

namespace pbgi::test {

inline std::filesystem::path temp_dir() {
  static const struct Dir {
    std::filesystem::path path =
        std::filesystem::temp_directory_path() / ("pbgi_ingest_test_" + std::to_string(getpid()));
    Dir() { std::filesystem::create_directories(path); }
    ~Dir() {
      std::error_code ec;
      std::filesystem::remove_all(path, ec);
    }
  } dir;
  return dir.path;
}

inline std::filesystem::path write_file(const std::string& name, const std::string& text) {
  const std::filesystem::path path = temp_dir() / name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

}  // namespace pbgi::test
