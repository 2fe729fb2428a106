// Files of the daemon's caches (page sets, ingested scenes) hold whole
// scenes' geometry and lighting: they are created private to the daemon's
// user (files 0600, directories 0700, whatever the umask), and the
// temporaries a crashed process left behind are removed by the next one.
#pragma once

#include <cstddef>
#include <filesystem>

namespace pbgi::storage {

inline constexpr std::filesystem::perms kPrivateFile =
    std::filesystem::perms::owner_read | std::filesystem::perms::owner_write;
inline constexpr std::filesystem::perms kPrivateDirectory = std::filesystem::perms::owner_all;

// Creates `dir` and its missing parents with mode 0700 (existing ones are
// left as they are: an operator may share a parent on purpose). Throws
// IoError naming the directory.
void create_private_directories(const std::filesystem::path& dir);

// Creates (or truncates) `file` with mode 0600, for writers that then open
// it by name (std::ofstream keeps the mode). Throws IoError naming it.
void create_private_file(const std::filesystem::path& file);

// Removes the entries of `dir` named "<name>.tmp-<pid>" or
// "<name>.tmp-<pid>-<suffix>" (files or directories) whose process no
// longer exists: writes of a process that was killed. Temporaries of live
// processes (this one included) are left alone; `dir` is assumed to be
// used by one host (process ids are host-local). Returns how many were
// removed; errors are ignored (the next start tries again).
size_t remove_stale_temporaries(const std::filesystem::path& dir);

}  // namespace pbgi::storage
