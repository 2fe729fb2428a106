// Run files of the external sort: compressed blocks that read back exactly,
// and damage reported as corruption naming the file and the block.
#include "storage/pages/run_file.h"

#include "common/errors.h"
#include "storage/pages/staging_quota.h"
#include "tests/storage/pages/temp_dir.h"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <random>
#include <string>

namespace pbgi::storage {
namespace {

namespace fs = std::filesystem;

constexpr size_t kRecord = 24;

// Records like a sorted run's: a slowly growing key, a field shared by
// neighbours and a random one.
std::vector<uint8_t> records(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<uint8_t> out(n * kRecord);
  for (size_t i = 0; i < n; ++i) {
    const uint64_t key = i * 3 + rng() % 3, shared = i / 50;
    const uint32_t noise = rng();
    std::memcpy(&out[i * kRecord], &key, 8);
    std::memcpy(&out[i * kRecord + 8], &shared, 8);
    std::memcpy(&out[i * kRecord + 16], &noise, 4);
  }
  return out;
}

std::vector<uint8_t> read_all(const fs::path& path, size_t n, RunCodec& codec) {
  RunReader r(path, n, kRecord, codec);
  std::vector<uint8_t> out, block(codec.block_bytes());
  while (const size_t got = r.read_block(block))
    out.insert(out.end(), block.begin(), block.begin() + std::ptrdiff_t(got * kRecord));
  return out;
}

void flip_byte(const fs::path& path, std::streamoff at) {
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  f.seekg(at);
  char c = 0;
  f.read(&c, 1);
  c ^= 0x21;
  f.seekp(at);
  f.write(&c, 1);
}

// The message of the CorruptionError `read_all` throws, or "" if none.
std::string corruption_of(const fs::path& path, size_t n, RunCodec& codec) {
  try {
    read_all(path, n, codec);
  } catch (const CorruptionError& e) {
    return e.what();
  }
  return "";
}

TEST(RunFile, BlocksReadBackExactlyAndCompressed) {
  test::TempDir tmp;
  RunCodec codec(100 * kRecord);  // blocks of 100 records
  const std::vector<uint8_t> want = records(2345, 1);
  StagingUsage usage;
  const fs::path path = tmp.path() / "run";
  RunWriter w(path, kRecord, codec, &usage);
  w.write({want.data(), 1000 * kRecord});  // two calls: blocks never span them
  w.write({want.data() + 1000 * kRecord, want.size() - 1000 * kRecord});
  w.close();
  EXPECT_EQ(w.bytes(), fs::file_size(path));
  EXPECT_EQ(usage.held(), w.bytes());     // every block charged before it was written
  EXPECT_LT(w.bytes(), want.size() / 2);  // sorted records share most of their bytes
  EXPECT_EQ(read_all(path, 2345, codec), want);
}

TEST(RunFile, DamageIsCorruptionNamingTheFileAndBlock) {
  test::TempDir tmp;
  RunCodec codec(100 * kRecord);
  const std::vector<uint8_t> want = records(300, 2);
  const fs::path path = tmp.path() / "run";
  RunWriter w(path, kRecord, codec, nullptr);
  w.write(want);
  w.close();
  const uint64_t size = fs::file_size(path);

  // A flipped byte in the first block's compressed bytes.
  fs::copy_file(path, tmp.path() / "a");
  flip_byte(tmp.path() / "a", kRunBlockHeaderBytes + 5);
  std::string e = corruption_of(tmp.path() / "a", 300, codec);
  EXPECT_NE(e.find((tmp.path() / "a").string()), std::string::npos) << e;
  EXPECT_NE(e.find("block at offset 0: checksum mismatch"), std::string::npos) << e;

  // A header that is not a run block's, and one that claims more records
  // than a block holds.
  fs::copy_file(path, tmp.path() / "b");
  flip_byte(tmp.path() / "b", 0);
  EXPECT_NE(corruption_of(tmp.path() / "b", 300, codec).find("not a run block"), std::string::npos);
  fs::copy_file(path, tmp.path() / "c");
  flip_byte(tmp.path() / "c", 9);
  EXPECT_NE(corruption_of(tmp.path() / "c", 300, codec).find("records (300 left, at most 100"), std::string::npos);

  // A truncated run, and a reader told of more records than were written.
  fs::copy_file(path, tmp.path() / "d");
  fs::resize_file(tmp.path() / "d", size - 3);
  EXPECT_FALSE(corruption_of(tmp.path() / "d", 300, codec).empty());
  EXPECT_FALSE(corruption_of(path, 301, codec).empty());
}

}  // namespace
}  // namespace pbgi::storage
