#include "storage/pages/run_file.h"

#include "common/errors.h"
#include "storage/format/checksum.h"
#include "storage/pages/staging_quota.h"

#include <tbb/parallel_for.h>
#include <zstd.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <string>

namespace pbgi::storage {

namespace fs = std::filesystem;

namespace {

// zstd's fastest standard level: runs are read once and deleted, so
// compression speed matters more than the last few percent of size.
constexpr int kLevel = 1;

// `path`, once records of `record_bytes` are known to fit blocks of `block_bytes`.
const fs::path& checked(const fs::path& path, size_t record_bytes, size_t block_bytes) {
  if (record_bytes == 0 || record_bytes > block_bytes) {
    throw InvalidArgument(path.string() + ": records of " + std::to_string(record_bytes) + " bytes in blocks of " +
                          std::to_string(block_bytes));
  }
  return path;
}

}  // namespace

struct RunCodec::Contexts {
  std::array<ZSTD_CCtx*, kRunParallelBlocks> compress{};
  ZSTD_DCtx* decompress = nullptr;
  ~Contexts() {
    for (ZSTD_CCtx* c : compress) ZSTD_freeCCtx(c);
    ZSTD_freeDCtx(decompress);
  }
};

RunCodec::RunCodec(size_t block_bytes)
    : block_bytes_(block_bytes), bound_(ZSTD_compressBound(block_bytes)), contexts_(std::make_unique<Contexts>()) {
  for (ZSTD_CCtx*& c : contexts_->compress) {
    c = ZSTD_createCCtx();
    if (!c) throw ResourceExhausted("run file: cannot allocate a zstd compression context");
  }
  contexts_->decompress = ZSTD_createDCtx();
  if (!contexts_->decompress) throw ResourceExhausted("run file: cannot allocate a zstd decompression context");
}

RunCodec::~RunCodec() = default;

size_t RunCodec::scratch_bytes(size_t block_bytes) { return kRunParallelBlocks * ZSTD_compressBound(block_bytes); }

void RunCodec::allocate_scratch() {
  if (scratch_.empty()) scratch_.resize(kRunParallelBlocks * bound_);
}

RunWriter::RunWriter(const fs::path& path, size_t record_bytes, RunCodec& codec, StagingUsage* usage)
    : file_(File::create_new(checked(path, record_bytes, codec.block_bytes()))),
      record_bytes_(record_bytes),
      codec_(codec),
      usage_(usage) {
  codec_.allocate_scratch();
}

void RunWriter::write(std::span<const uint8_t> bytes) {
  const size_t block = codec_.block_bytes() / record_bytes_ * record_bytes_;
  const size_t blocks = (bytes.size() + block - 1) / block;
  std::array<size_t, kRunParallelBlocks> sizes{};
  for (size_t first = 0; first < blocks; first += kRunParallelBlocks) {
    const size_t group = std::min(kRunParallelBlocks, blocks - first);
    tbb::parallel_for(size_t(0), group, [&](size_t i) {
      const size_t at = (first + i) * block, n = std::min(block, bytes.size() - at);
      sizes[i] = ZSTD_compressCCtx(codec_.contexts_->compress[i], codec_.scratch(i), codec_.bound(), bytes.data() + at,
                                   n, kLevel);
    });
    for (size_t i = 0; i < group; ++i) {
      if (ZSTD_isError(sizes[i])) {
        throw IoError(file_.path() + ": compressing a run block: " + ZSTD_getErrorName(sizes[i]));
      }
      const size_t at = (first + i) * block, n = std::min(block, bytes.size() - at);
      const uint64_t header[4] = {kRunBlockTag, n / record_bytes_, sizes[i], checksum64(codec_.scratch(i), sizes[i])};
      if (usage_) usage_->charge(kRunBlockHeaderBytes + sizes[i], file_.path());
      file_.write_all({reinterpret_cast<const uint8_t*>(header), kRunBlockHeaderBytes});
      file_.write_all({codec_.scratch(i), sizes[i]});
      bytes_ += kRunBlockHeaderBytes + sizes[i];
    }
  }
}

RunReader::RunReader(const fs::path& path, uint64_t records, size_t record_bytes, RunCodec& codec)
    : file_(File::open_read(path)), remaining_(records), record_bytes_(record_bytes), codec_(codec) {
  codec_.allocate_scratch();
}

void RunReader::corrupt(const std::string& what) const {
  throw CorruptionError(file_.path() + ": run block at offset " + std::to_string(offset_) + ": " + what);
}

size_t RunReader::read_block(std::span<uint8_t> out) {
  if (remaining_ == 0) return 0;
  uint64_t header[4];
  file_.pread_exact({reinterpret_cast<uint8_t*>(header), kRunBlockHeaderBytes}, offset_);
  const uint64_t max_records = std::min<uint64_t>(out.size(), codec_.block_bytes()) / record_bytes_;
  if (header[0] != kRunBlockTag) corrupt("not a run block of this version (tag " + checksum_hex(header[0]) + ")");
  if (header[1] == 0 || header[1] > max_records || header[1] > remaining_) {
    corrupt("claims " + std::to_string(header[1]) + " records (" + std::to_string(remaining_) + " left, at most " +
            std::to_string(max_records) + " per block)");
  }
  if (header[2] == 0 || header[2] > codec_.bound())
    corrupt("claims " + std::to_string(header[2]) + " compressed bytes");
  uint8_t* packed = codec_.scratch(0);
  file_.pread_exact({packed, header[2]}, offset_ + kRunBlockHeaderBytes);
  const uint64_t found = checksum64(packed, header[2]);
  if (found != header[3])
    corrupt("checksum mismatch: expected " + checksum_hex(header[3]) + ", found " + checksum_hex(found));
  const size_t want = header[1] * record_bytes_;
  const size_t got = ZSTD_decompressDCtx(codec_.contexts_->decompress, out.data(), want, packed, header[2]);
  if (ZSTD_isError(got) || got != want) {
    corrupt(ZSTD_isError(got) ? std::string("cannot decompress: ") + ZSTD_getErrorName(got)
                              : "decompressed to " + std::to_string(got) + " bytes, not " + std::to_string(want));
  }
  offset_ += kRunBlockHeaderBytes + header[2];
  remaining_ -= header[1];
  return header[1];
}

}  // namespace pbgi::storage
