#include "client/cli/output_paths.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

namespace fs = std::filesystem;

namespace pbgi::cli {

void check_output_file(const std::string& path, const char* flag) {
  if (path.empty()) throw InvalidArgument(fmt::format("{} is empty", flag));
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    throw InvalidArgument(fmt::format("{} '{}' is a directory; give a file name, e.g. '{}'", flag, path,
                                      (fs::path(path) / "render.exr").string()));
  }
  const fs::path parent = fs::path(path).parent_path();
  const fs::path dir = parent.empty() ? fs::path(".") : parent;
  const fs::file_status status = fs::status(dir, ec);
  if (!fs::exists(status)) {
    throw InvalidArgument(fmt::format("{} '{}': directory '{}' does not exist", flag, path, dir.string()));
  }
  if (!fs::is_directory(status)) {
    throw InvalidArgument(fmt::format("{} '{}': '{}' is not a directory", flag, path, dir.string()));
  }
  if (::access(dir.c_str(), W_OK | X_OK) != 0) {
    throw InvalidArgument(
        fmt::format("{} '{}': cannot write to directory '{}': {}", flag, path, dir.string(), std::strerror(errno)));
  }
}

}  // namespace pbgi::cli
