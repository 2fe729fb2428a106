#include "storage/pages/file_io.h"

#include "common/errors.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace pbgi::storage {

namespace {
[[noreturn]] void fail(const std::string& what, const std::string& path, int err) {
  throw IoError(path + ": " + what + ": " + std::strerror(err));
}
}  // namespace

File File::open_read(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    if (errno == ENOENT) throw NotFound(path.string() + ": no such file");
    fail("cannot open for reading", path.string(), errno);
  }
  return File(fd, path.string());
}

File File::create_new(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) fail("cannot create", path.string(), errno);
  return File(fd, path.string());
}

File::File(File&& o) noexcept : fd_(o.fd_), path_(std::move(o.path_)) { o.fd_ = -1; }

File& File::operator=(File&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = o.fd_;
    path_ = std::move(o.path_);
    o.fd_ = -1;
  }
  return *this;
}

File::~File() {
  if (fd_ >= 0) ::close(fd_);
}

void File::write_all(std::span<const uint8_t> bytes) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("write of " + std::to_string(bytes.size() - done) + " bytes failed", path_, errno);
    }
    done += static_cast<size_t>(n);
  }
}

void File::pread_exact(std::span<uint8_t> out, uint64_t offset) const {
  size_t done = 0;
  while (done < out.size()) {
    const ssize_t n = ::pread(fd_, out.data() + done, out.size() - done, static_cast<off_t>(offset + done));
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("read of " + std::to_string(out.size()) + " bytes at offset " + std::to_string(offset) +
               " failed",
           path_, errno);
    }
    if (n == 0) {
      throw CorruptionError(path_ + ": truncated: read of " + std::to_string(out.size()) +
                            " bytes at offset " + std::to_string(offset) + " ended after " +
                            std::to_string(done) + " bytes");
    }
    done += static_cast<size_t>(n);
  }
}

uint64_t File::size() const {
  struct stat st;
  if (::fstat(fd_, &st) != 0) fail("fstat failed", path_, errno);
  return static_cast<uint64_t>(st.st_size);
}

void File::sync() {
  if (::fsync(fd_) != 0) fail("fsync failed", path_, errno);
}

void File::close() {
  const int fd = fd_;
  fd_ = -1;
  if (fd >= 0 && ::close(fd) != 0) fail("close failed", path_, errno);
}

void sync_directory(const std::filesystem::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) fail("cannot open directory for fsync", dir.string(), errno);
  const int rc = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0) fail("directory fsync failed", dir.string(), err);
}

std::vector<uint8_t> read_whole_file(const std::filesystem::path& path) {
  File f = File::open_read(path);
  std::vector<uint8_t> bytes(f.size());
  f.pread_exact(bytes, 0);
  return bytes;
}

}  // namespace pbgi::storage
