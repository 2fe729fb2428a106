#include "server/service/secret_files.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace pbgi::service {

void check_secret_file_mode(const std::filesystem::path& file, const std::string& what) {
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0) {
    throw IoError(fmt::format("cannot read {} '{}': {}", what, file.string(), std::strerror(errno)));
  }
  const mode_t mode = st.st_mode & 0777;
  const bool others = (mode & 0007) != 0;
  const bool group_writes = (mode & 0020) != 0;
  const bool foreign_group_reads = (mode & 0040) != 0 && st.st_gid != ::getegid();
  if (others || group_writes || foreign_group_reads) {
    throw InvalidArgument(fmt::format("{} '{}' is readable or writable by other users (mode {:o}); chmod 600 it",
                                      what, file.string(), mode));
  }
}

}  // namespace pbgi::service
