// Files that hold secrets (the bearer token file, the TLS private key) must
// be private to the daemon: a secret other users can read is no secret.
#pragma once

#include <filesystem>
#include <string>

namespace pbgi::service {

// Throws IoError naming `what` and the file if it cannot be stat'ed, and
// InvalidArgument naming them (and the mode) if users other than the
// daemon's may read or change it: any permission for others, write for the
// group, or read for a group other than the daemon's own (effective) group.
// The last case is allowed because Kubernetes mounts Secret files with the
// pod's fsGroup readable (mode 0440, group = the daemon's group).
void check_secret_file_mode(const std::filesystem::path& file, const std::string& what);

}  // namespace pbgi::service
