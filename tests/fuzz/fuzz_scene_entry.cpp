// libFuzzer target: the reader of the daemon's ingested-scene entries
// (<cache>/ingested/*.pbgiscene, server/ingest/scene_entry.h), as the chunk
// store calls it: head, then body. Each input is tried twice: as stored
// (almost always stopped by a checksum), and re-sealed -- its dependencies
// and body framed again with correct sizes and checksums -- so that the
// stream decoder and Draco behind the checksums see the damage too. Every
// outcome is a scene or a pbgi::Error, never a crash.
//
// The dependency lines are only read here, not checked: the chunk store
// hashes the files they name, which a fuzzer must not open.
#include "common/errors.h"
#include "server/ingest/scene_entry.h"
#include "storage/format/byte_order.h"

#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

namespace {

void read_entry(const char* data, size_t size) {
  const int fd = memfd_create("scene-entry", 0);
  if (fd < 0) return;
  size_t written = 0;
  while (written < size) {
    const ssize_t n = write(fd, data + written, size - written);
    if (n <= 0) break;
    written += static_cast<size_t>(n);
  }
  try {
    const pbgi::SceneEntryHead head = pbgi::read_scene_entry_head(fd, "fuzz.pbgiscene");
    const pbgi::Scene scene = pbgi::read_scene_entry_body(fd, head, "fuzz.pbgiscene");
    (void)scene;
  } catch (const pbgi::Error&) {
  }
  close(fd);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using pbgi::storage::load_le;
  // 1. As stored.
  read_entry(reinterpret_cast<const char*>(data), size);
  // 2. Re-sealed: the dependencies its head claims (if they fit), the rest as body.
  const std::string input(reinterpret_cast<const char*>(data), size);
  std::string dependencies, body = input;
  const size_t fixed = pbgi::kSceneEntryHeadBytes + pbgi::kSceneEntryChecksumBytes;
  if (size >= fixed) {
    const uint64_t d = load_le<uint64_t>(data + 8);
    if (d <= pbgi::kMaxSceneEntryDependencyBytes && d <= size - fixed) {
      dependencies = input.substr(pbgi::kSceneEntryHeadBytes, d);
      body = input.substr(fixed + d);
    }
  }
  std::stringstream sealed;
  pbgi::SceneEntryWriter writer(sealed, dependencies);
  writer.append(body.data(), body.size());
  writer.finish("fuzz.pbgiscene");
  const std::string bytes = sealed.str();
  read_entry(bytes.data(), bytes.size());
  return 0;
}
