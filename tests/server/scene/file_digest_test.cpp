// file_digest: the content key of scene files. Equal bytes give equal
// digests, any changed byte another; a file that cannot be read whole has
// none. (Its three former copies returned "unreadable", "missing" or threw
// for a missing file, and all gave a directory the digest of an empty file.)
#include "server/scene/file_digest.h"

#include <gtest/gtest.h>
#include <xxhash.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

class FileDigest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("pbgi_file_digest_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path write(const std::string& name, const std::string& bytes) {
    const fs::path p = dir_ / name;
    std::ofstream(p, std::ios::binary) << bytes;
    return p;
  }
  fs::path dir_;
};

std::string xxh64_hex(const std::string& bytes) {
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(XXH64(bytes.data(), bytes.size(), 0)));
  return hex;
}

TEST_F(FileDigest, IsTheXxh64OfTheWholeFile) {
  // Larger than the 1 MiB read buffer, so the digest spans several reads.
  std::string bytes(size_t(1) << 20, 'a');
  bytes += "tail";
  const auto digest = file_digest(write("big.bin", bytes));
  ASSERT_TRUE(digest.has_value());
  EXPECT_EQ(*digest, xxh64_hex(bytes));
  EXPECT_EQ(file_digest(write("empty.bin", "")), xxh64_hex(""));
}

TEST_F(FileDigest, FollowsTheContentNotTheName) {
  EXPECT_EQ(file_digest(write("a.usda", "#usda 1.0\n")), file_digest(write("b.usda", "#usda 1.0\n")));
  EXPECT_NE(file_digest(write("a.usda", "#usda 1.0\n")), file_digest(write("c.usda", "#usda 1.1\n")));
}

TEST_F(FileDigest, NoneForWhatCannotBeReadWhole) {
  EXPECT_FALSE(file_digest(dir_ / "missing.usda").has_value());
  EXPECT_FALSE(file_digest(dir_).has_value()) << "a directory opens but cannot be read";
}

}  // namespace
}  // namespace pbgi
