// Thin RAII wrappers over POSIX file descriptors for the page-set files:
// exact reads with pread (thread-safe on one descriptor), complete writes,
// fsync. Every failure throws IoError naming the path, offset and errno text.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace pbgi::storage {

class File {
 public:
  // Opens an existing file for reading. NotFound if it does not exist.
  static File open_read(const std::filesystem::path& path);
  // Creates a new file for writing, mode 0600 (cache_files.h); fails if
  // it exists (O_EXCL).
  static File create_new(const std::filesystem::path& path);

  File(File&& o) noexcept;
  File& operator=(File&& o) noexcept;
  File(const File&) = delete;
  File& operator=(const File&) = delete;
  ~File();

  // Writes all of `bytes` at the current position.
  void write_all(std::span<const uint8_t> bytes);
  // Reads exactly out.size() bytes at `offset`; a short read (the file is
  // shorter than expected) throws CorruptionError, a failed one IoError.
  void pread_exact(std::span<uint8_t> out, uint64_t offset) const;
  uint64_t size() const;
  void sync();
  // Closes and reports errors (the destructor closes silently).
  void close();
  const std::string& path() const { return path_; }

 private:
  File(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}
  int fd_ = -1;
  std::string path_;
};

// fsyncs a directory so that entries created or renamed in it are durable.
void sync_directory(const std::filesystem::path& dir);

// Reads a whole (small) file.
std::vector<uint8_t> read_whole_file(const std::filesystem::path& path);

}  // namespace pbgi::storage
