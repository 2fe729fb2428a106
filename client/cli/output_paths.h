// Output files are checked before the work that produces them: a render
// must not run for minutes and then fail to write its image because --out
// names a directory or a directory that does not exist.
#pragma once

#include <string>

namespace pbgi::cli {

// Throws InvalidArgument naming `flag`, the path and the reason unless
// `path` can be created as a file: it is not empty and not a directory,
// and its directory exists (and is a directory we may write to).
void check_output_file(const std::string& path, const char* flag);

}  // namespace pbgi::cli
