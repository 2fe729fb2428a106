#include "server/ingest/scene_entry.h"

#include "common/errors.h"
#include "storage/format/byte_order.h"
#include "storage/format/format_version.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <vector>

#include <fmt/format.h>

namespace pbgi {
namespace {

using storage::checksum_hex;
using storage::load_le;
using storage::store_le;

// pread of exactly n bytes at `offset`; fewer only at EOF.
size_t read_at(int fd, void* dst, size_t n, uint64_t offset, const std::string& path) {
  size_t got = 0;
  while (got < n) {
    const ssize_t r = ::pread(fd, static_cast<char*>(dst) + got, n - got, static_cast<off_t>(offset + got));
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) throw IoError(fmt::format("scene entry '{}': read at offset {} failed: {}", path, offset + got,
                                         std::strerror(errno)));
    if (r == 0) break;
    got += static_cast<size_t>(r);
  }
  return got;
}

[[noreturn]] void corrupt(const std::string& path, const std::string& what) {
  throw CorruptionError(fmt::format("scene entry '{}': {}", path, what));
}

}  // namespace

SceneEntryWriter::SceneEntryWriter(std::ostream& out, std::string dependencies)
    : out_(out), dependencies_(std::move(dependencies)) {
  if (dependencies_.size() > kMaxSceneEntryDependencyBytes)
    throw InvalidArgument(fmt::format("scene entry: {} bytes of dependencies exceed the limit of {}",
                                      dependencies_.size(), kMaxSceneEntryDependencyBytes));
  const std::string placeholder(kSceneEntryHeadBytes + dependencies_.size() + kSceneEntryChecksumBytes, '\0');
  out_.write(placeholder.data(), static_cast<std::streamsize>(placeholder.size()));
}

void SceneEntryWriter::append(const void* data, size_t size) {
  out_.write(static_cast<const char*>(data), static_cast<std::streamsize>(size));
  body_checksum_.update(data, size);
  body_bytes_ += size;
}

void SceneEntryWriter::finish(const std::string& path) {
  std::vector<uint8_t> head(kSceneEntryHeadBytes + dependencies_.size() + kSceneEntryChecksumBytes);
  store_le<uint32_t>(head.data(), storage::kSceneEntryMagic);
  store_le<uint32_t>(head.data() + 4, storage::kSceneEntryFormatV5);
  store_le<uint64_t>(head.data() + 8, dependencies_.size());
  store_le<uint64_t>(head.data() + 16, body_bytes_);
  store_le<uint64_t>(head.data() + 24, body_checksum_.digest());
  std::memcpy(head.data() + kSceneEntryHeadBytes, dependencies_.data(), dependencies_.size());
  const size_t covered = kSceneEntryHeadBytes + dependencies_.size();
  store_le<uint64_t>(head.data() + covered, storage::checksum64(head.data(), covered));
  out_.seekp(0);
  out_.write(reinterpret_cast<const char*>(head.data()), static_cast<std::streamsize>(head.size()));
  out_.seekp(0, std::ios::end);
  out_.flush();
  if (!out_) throw IoError(fmt::format("scene entry '{}': writing failed (disk full?)", path));
}

SceneEntryHead read_scene_entry_head(int fd, const std::string& path) {
  uint8_t fixed[kSceneEntryHeadBytes];
  const size_t got = read_at(fd, fixed, sizeof fixed, 0, path);
  if (got < sizeof fixed) corrupt(path, fmt::format("only {} bytes, shorter than the {}-byte head", got, sizeof fixed));
  const uint32_t magic = load_le<uint32_t>(fixed);
  if (magic != storage::kSceneEntryMagic)
    corrupt(path, fmt::format("bad magic at offset 0: expected 0x{:08x} ('PBGS'), found 0x{:08x} (an entry of "
                              "an older build, or not an entry)",
                              storage::kSceneEntryMagic, magic));
  SceneEntryHead head;
  head.version = load_le<uint32_t>(fixed + 4);
  if (!storage::is_known_scene_entry_format(head.version))
    throw VersionError(fmt::format("scene entry '{}': format version {} at offset 4 is not one this build reads "
                                   "(it reads {})",
                                   path, head.version, storage::kSceneEntryFormatV5));
  const uint64_t dependency_bytes = load_le<uint64_t>(fixed + 8);
  head.body_bytes = load_le<uint64_t>(fixed + 16);
  head.body_checksum = load_le<uint64_t>(fixed + 24);
  // Bounded before anything is allocated by it; the checksum confirms it.
  if (dependency_bytes > kMaxSceneEntryDependencyBytes)
    corrupt(path, fmt::format("dependency_bytes {} at offset 8 exceed the limit of {}", dependency_bytes,
                              kMaxSceneEntryDependencyBytes));
  struct stat st {};
  if (::fstat(fd, &st) != 0)
    throw IoError(fmt::format("scene entry '{}': fstat failed: {}", path, std::strerror(errno)));
  const uint64_t size = static_cast<uint64_t>(st.st_size);
  head.body_offset = kSceneEntryHeadBytes + dependency_bytes + kSceneEntryChecksumBytes;
  if (size < head.body_offset || size - head.body_offset != head.body_bytes)
    corrupt(path, fmt::format("the file has {} bytes, but its head (offsets 8 and 16) describes {} bytes of "
                              "dependencies and {} of body: truncated or extended",
                              size, dependency_bytes, head.body_bytes));

  std::vector<uint8_t> covered(kSceneEntryHeadBytes + dependency_bytes + kSceneEntryChecksumBytes);
  std::memcpy(covered.data(), fixed, sizeof fixed);
  const size_t rest = covered.size() - sizeof fixed;
  if (read_at(fd, covered.data() + sizeof fixed, rest, sizeof fixed, path) < rest)
    corrupt(path, "truncated while reading the head");
  const size_t checksum_at = covered.size() - kSceneEntryChecksumBytes;
  const uint64_t stored = load_le<uint64_t>(covered.data() + checksum_at);
  const uint64_t found = storage::checksum64(covered.data(), checksum_at);
  if (stored != found)
    corrupt(path, fmt::format("head checksum mismatch at offset {}: expected {}, found {}", checksum_at,
                              checksum_hex(stored), checksum_hex(found)));
  head.dependencies.assign(reinterpret_cast<const char*>(covered.data()) + kSceneEntryHeadBytes, dependency_bytes);
  return head;
}

Scene read_scene_entry_body(int fd, const SceneEntryHead& head, const std::string& path,
                            const SceneStreamDecoder::Progress& progress, const TextureLoadOptions& textures,
                            const SceneReadMemory& memory) {
  // 1. The checksum, streamed.
  storage::Checksum64Stream checksum;
  std::vector<char> buffer(size_t(1) << 20);
  uint64_t done = 0;
  while (done < head.body_bytes) {
    const size_t want = static_cast<size_t>(std::min<uint64_t>(buffer.size(), head.body_bytes - done));
    const size_t got = read_at(fd, buffer.data(), want, head.body_offset + done, path);
    checksum.update(buffer.data(), got);
    done += got;
    if (got < want) corrupt(path, fmt::format("truncated at offset {} inside the body", head.body_offset + done));
  }
  if (checksum.digest() != head.body_checksum)
    corrupt(path, fmt::format("body checksum mismatch over bytes [{}, {}): expected {}, found {}", head.body_offset,
                              head.body_offset + head.body_bytes, checksum_hex(head.body_checksum),
                              checksum_hex(checksum.digest())));
  // 2. The scene: the body runs to the end of the file (the head said so).
  if (::lseek(fd, static_cast<off_t>(head.body_offset), SEEK_SET) < 0)
    throw IoError(fmt::format("scene entry '{}': seek failed: {}", path, std::strerror(errno)));
  SceneStreamDecoder decoder(path, progress, {}, textures);
  decoder.set_memory(memory);
  return decoder.decode(fd);
}

}  // namespace pbgi
