#include "client/cli/tool_commands.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>

namespace pbgi::cli {

int exec_tool(int argc, char** argv) {
  std::error_code ec;
  // The executable itself, not argv[0]: pbgi may be run through PATH or a
  // symlink; pbgi-tools is built and installed beside it.
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  const std::filesystem::path tool = (ec ? std::filesystem::path(argv[0]) : self).parent_path() / "pbgi-tools";
  ::execv(tool.c_str(), argv);
  const int err = errno;
  std::fprintf(stderr, "pbgi: '%s' runs in pbgi-tools, which could not be started (%s: %s)\n", argc > 1 ? argv[1] : "",
               tool.c_str(), std::strerror(err));
  return 127;
}

}  // namespace pbgi::cli
