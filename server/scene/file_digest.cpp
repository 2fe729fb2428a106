#include "server/scene/file_digest.h"

#include <fmt/format.h>
#include <xxhash.h>

#include <fstream>
#include <memory>
#include <vector>

namespace pbgi {

std::optional<std::string> file_digest(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  const std::unique_ptr<XXH64_state_t, decltype(&XXH64_freeState)> state(XXH64_createState(), &XXH64_freeState);
  XXH64_reset(state.get(), 0);
  std::vector<char> buffer(size_t(1) << 20);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    XXH64_update(state.get(), buffer.data(), static_cast<size_t>(in.gcount()));
  }
  // The loop ends at end of file (eofbit) or on a failed read (badbit,
  // e.g. EISDIR): only the first is a whole file.
  if (in.bad() || !in.eof()) return std::nullopt;
  return fmt::format("{:016x}", XXH64_digest(state.get()));
}

}  // namespace pbgi
