// libFuzzer target: the decoder of the USD reader's framed SceneChunk
// stream (the daemon's trust boundary with the reader process). The input
// is the stream, fed through a memfd as the pipe would; it must decode or
// throw a pbgi::Error naming the frame, never crash.
#include "common/errors.h"
#include "server/ingest/scene_stream_decoder.h"

#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const int fd = memfd_create("scene-stream", 0);
  if (fd < 0) return 0;
  size_t written = 0;
  while (written < size) {
    const ssize_t n = write(fd, data + written, size - written);
    if (n <= 0) break;
    written += static_cast<size_t>(n);
  }
  lseek(fd, 0, SEEK_SET);
  try {
    pbgi::SceneStreamDecoder decoder("fuzz.usda");
    const pbgi::Scene scene = decoder.decode(fd);
    (void)scene;
  } catch (const pbgi::Error&) {
  }
  close(fd);
  return 0;
}
