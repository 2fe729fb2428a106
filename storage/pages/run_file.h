// The run files of the external surfel sort (surfel_sorter.h): temporary
// files of fixed-size records, written in blocks, each block compressed
// with zstd.
//
// Why compressed. A run holds the sort's records as they lie in memory
// (96 bytes a surfel), so the runs of a build take ~5x the disk of the page
// set it writes (18-19 bytes a surfel): 1 billion surfels would stage ~96
// GB. Sorted by Morton code, neighbouring records share most of their bytes
// (one surface: one normal, one albedo, near positions; emission and gloss
// mostly zero), and zstd's fastest level takes a run of the generated city
// from 268 MB to 54 MB (5.0x) at ~640 MB/s a core; the 10.4M city's
// tree stage took 6% longer with it (docs/measurements/
// 2026-11-28-billion-surfels.md).
//
// Block layout (host byte order: a run never leaves the process that wrote
// it):
//
//   u64 magic | format version   kRunBlockTag
//   u64 record count             1 .. the reader's block size
//   u64 compressed bytes         the zstd frame that follows
//   u64 XXH3-64 of those bytes   checked before they are decompressed
//   zstd frame                   the records, exactly count * record size
//
// Thread-safety: a RunCodec and the readers and writers that use it belong
// to one thread, but for RunWriter::write, which compresses the blocks of
// one call on several threads (TBB).
#pragma once

#include "storage/pages/file_io.h"

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <vector>

namespace pbgi::storage {

class StagingUsage;

// "PBGIRUN" and format version 2 (version 1: raw blocks, no magic).
inline constexpr uint64_t kRunBlockTag = 0x50424749'52554E00ull | 2u;
inline constexpr size_t kRunBlockHeaderBytes = 32;
// Blocks a writer compresses at once: its scratch is this many compressed
// blocks (RunCodec::scratch_bytes).
inline constexpr size_t kRunParallelBlocks = 4;

// The compressor and decompressor states and the scratch space for
// compressed blocks of at most `block_bytes` of records, shared by the
// readers and writers of one sort.
class RunCodec {
 public:
  explicit RunCodec(size_t block_bytes);
  ~RunCodec();
  RunCodec(const RunCodec&) = delete;
  RunCodec& operator=(const RunCodec&) = delete;

  size_t block_bytes() const { return block_bytes_; }
  // The most a compressed block of block_bytes can take.
  size_t bound() const { return bound_; }
  // Bytes of compressed blocks held while a writer compresses
  // (kRunParallelBlocks of bound()); a reader uses the first of them.
  static size_t scratch_bytes(size_t block_bytes);

 private:
  friend class RunWriter;
  friend class RunReader;
  struct Contexts;
  size_t block_bytes_, bound_;
  std::vector<uint8_t> scratch_;  // kRunParallelBlocks * bound_, allocated by the first reader or writer
  std::unique_ptr<Contexts> contexts_;
  void allocate_scratch();
  uint8_t* scratch(size_t i) { return scratch_.data() + i * bound_; }
};

class RunWriter {
 public:
  // `usage` (may be null) is charged before each block is written.
  RunWriter(const std::filesystem::path& path, size_t record_bytes, RunCodec& codec, StagingUsage* usage);

  // Writes `bytes` (whole records) as blocks of at most codec.block_bytes().
  void write(std::span<const uint8_t> bytes);
  void close() { file_.close(); }
  // Bytes written to the file so far.
  uint64_t bytes() const { return bytes_; }

 private:
  File file_;
  size_t record_bytes_;
  RunCodec& codec_;
  StagingUsage* usage_;
  uint64_t bytes_ = 0;
};

class RunReader {
 public:
  // A run of `records` records written by RunWriter with a codec of the
  // same block size.
  RunReader(const std::filesystem::path& path, uint64_t records, size_t record_bytes, RunCodec& codec);

  // Reads the next block into `out` (codec.block_bytes() at least) and
  // returns its records, 0 at the end of the run. A damaged or truncated
  // block throws CorruptionError naming the file and the block's offset.
  size_t read_block(std::span<uint8_t> out);

 private:
  [[noreturn]] void corrupt(const std::string& what) const;

  File file_;
  uint64_t remaining_;
  size_t record_bytes_;
  RunCodec& codec_;
  uint64_t offset_ = 0;
};

}  // namespace pbgi::storage
