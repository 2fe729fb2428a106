#include "storage/pages/surfel_sorter.h"

#include "common/errors.h"
#include "storage/pages/run_file.h"
#include "storage/pages/staging_quota.h"

#include <tbb/parallel_sort.h>

#include <algorithm>
#include <deque>
#include <queue>
#include <string>
#include <type_traits>
#include <vector>

namespace pbgi::storage {

namespace fs = std::filesystem;

namespace {

// What a run holds per surfel; compared by (region, code, index). Plain
// floats (Imath types are not trivially copyable) so that blocks are raw
// bytes. The region shares a word with the arrival index (< 2^40).
constexpr int kRegionShift = 40;
constexpr uint64_t kIndexMask = (uint64_t(1) << kRegionShift) - 1;

struct Record {
  uint64_t code;
  uint64_t region_index;  // region << 40 | arrival order (breaks ties, so the order is total)
  float f[20];            // position, normal, radius, albedo, emission, radiance, gloss

  uint64_t region() const { return region_index >> kRegionShift; }
  bool operator<(const Record& o) const {
    if (region() != o.region()) return region() < o.region();
    return code != o.code ? code < o.code : region_index < o.region_index;
  }

  static Record of(uint64_t code, uint64_t index, const Surfel& s) {
    return {code,
            uint64_t(s.region) << kRegionShift | (index & kIndexMask),
            {s.position.x, s.position.y, s.position.z,  s.normal.x,   s.normal.y,   s.normal.z,   s.radius,
             s.albedo.x,   s.albedo.y,   s.albedo.z,    s.emission.x, s.emission.y, s.emission.z, s.radiance.x,
             s.radiance.y, s.radiance.z, s.gloss.alpha, s.gloss.f0.x, s.gloss.f0.y, s.gloss.f0.z}};
  }
  Surfel surfel() const {
    Surfel s;
    s.position = {f[0], f[1], f[2]};
    s.normal = {f[3], f[4], f[5]};
    s.radius = f[6];
    s.albedo = {f[7], f[8], f[9]};
    s.emission = {f[10], f[11], f[12]};
    s.radiance = {f[13], f[14], f[15]};
    s.gloss.alpha = f[16];
    s.gloss.f0 = {f[17], f[18], f[19]};
    s.region = uint32_t(region());
    return s;
  }
};
static_assert(std::is_trivially_copyable_v<Record> && sizeof(Record) == 96);

constexpr size_t kMaxBlockRecords = 16384;  // ~1.5 MB: enough to make reads sequential

// The records of one run, a block at a time.
class RunCursor {
 public:
  RunCursor(const fs::path& path, uint64_t records, size_t block_records, RunCodec& codec)
      : file_(path, records, sizeof(Record), codec), block_(block_records) {}

  // The next record, or nullptr at the end.
  const Record* peek() {
    if (pos_ == size_) {
      size_ = file_.read_block({reinterpret_cast<uint8_t*>(block_.data()), block_.size() * sizeof(Record)});
      pos_ = 0;
      if (size_ == 0) return nullptr;
    }
    return &block_[pos_];
  }
  void pop() { ++pos_; }

 private:
  RunReader file_;
  std::vector<Record> block_;
  size_t size_ = 0, pos_ = 0;
};

std::span<const uint8_t> bytes_of(std::span<const Record> records) {
  return {reinterpret_cast<const uint8_t*>(records.data()), records.size_bytes()};
}

}  // namespace

struct SurfelSorter::Impl {
  struct Run {
    fs::path path;
    uint64_t records = 0;
    uint64_t bytes = 0;
  };

  tree::MortonFrame frame;
  uint64_t memory;
  fs::path dir;
  StagingUsage* usage;  // may be null
  size_t block_records;
  uint32_t fan_in;
  size_t capacity;  // records in the run buffer
  std::unique_ptr<RunCodec> codec;
  std::vector<Record> buffer;
  std::deque<Run> runs;
  uint32_t serial = 0;
  SortStats stats;
  bool drained = false;

  Impl(const tree::MortonFrame& f, uint64_t mem, fs::path d, uint32_t max_fan_in, StagingUsage* u)
      : frame(f), memory(mem), dir(std::move(d)), usage(u) {
    if (memory < 64 * 1024) throw InvalidArgument("sort memory of " + std::to_string(memory) + " bytes: at least 64 KiB");
    max_fan_in = std::max<uint32_t>(max_fan_in, 2);
    // Merge memory: fan_in input blocks, one output block and the codec's
    // scratch (kRunParallelBlocks compressed blocks, a little more than as
    // many blocks); a spill: the run buffer and the scratch.
    const auto scratch = [](size_t records) { return RunCodec::scratch_bytes(records * sizeof(Record)); };
    block_records = std::clamp<size_t>(memory / ((size_t(max_fan_in) + 1 + kRunParallelBlocks) * sizeof(Record)), 1,
                                       kMaxBlockRecords);
    // The least merge (two inputs and the output) must fit with the scratch.
    constexpr size_t kLeastMergeBlocks = 3;
    while (block_records > 1 && kLeastMergeBlocks * block_records * sizeof(Record) + scratch(block_records) > memory) {
      --block_records;
    }
    const uint64_t room = memory - scratch(block_records);
    fan_in = uint32_t(std::clamp<uint64_t>(room / (block_records * sizeof(Record)) - 1, 2, max_fan_in));
    capacity = room / sizeof(Record);
    codec = std::make_unique<RunCodec>(block_records * sizeof(Record));
  }

  ~Impl() {
    std::error_code ec;  // best effort
    for (const Run& r : runs) {
      fs::remove(r.path, ec);
      if (usage) usage->release(r.bytes);
    }
  }

  void note_peak(uint64_t bytes) { stats.peak_bytes = std::max(stats.peak_bytes, bytes); }

  fs::path next_run_path() {
    char name[32];
    std::snprintf(name, sizeof name, "run-%06u.tmp", serial++);
    return dir / name;
  }

  void spill() {
    if (buffer.empty()) return;
    tbb::parallel_sort(buffer.begin(), buffer.end());
    Run run{next_run_path(), buffer.size()};
    RunWriter w(run.path, sizeof(Record), *codec, usage);
    w.write(bytes_of(buffer));
    w.close();
    run.bytes = w.bytes();
    stats.run_bytes += w.bytes();
    ++stats.runs;
    runs.push_back(std::move(run));
    buffer.clear();
  }

  void add(std::span<const Surfel> surfels) {
    if (drained) throw InvalidArgument("surfel sorter: add() after drain()");
    if (buffer.capacity() < capacity) {
      // Reserve the whole run buffer at once: it is the budget, and growth
      // by doubling would briefly need 1.5 times it.
      buffer.reserve(capacity);
      note_peak(buffer.capacity() * sizeof(Record) + RunCodec::scratch_bytes(codec->block_bytes()));
    }
    for (const Surfel& s : surfels) {
      if (s.region > kMaxSortedRegion) {
        throw InvalidArgument("surfel " + std::to_string(stats.surfels) + ": air region " + std::to_string(s.region) +
                              " is above " + std::to_string(kMaxSortedRegion));
      }
      if (buffer.size() == capacity) spill();
      buffer.push_back(Record::of(frame.code(s.position), stats.surfels++, s));
    }
  }

  // Merges `inputs` (removed from disk afterwards), handing each record to
  // `out`; `tick` after each record.
  template <typename Out>
  void merge(const std::vector<Run>& inputs, Out&& out, const std::function<void()>& tick) {
    std::vector<std::unique_ptr<RunCursor>> readers;
    readers.reserve(inputs.size());
    for (const Run& r : inputs)
      readers.push_back(std::make_unique<RunCursor>(r.path, r.records, block_records, *codec));
    struct Head {
      uint64_t code, region_index;
      uint32_t reader;
      bool operator>(const Head& o) const {
        const uint64_t a = region_index >> kRegionShift, b = o.region_index >> kRegionShift;
        if (a != b) return a > b;
        return code != o.code ? code > o.code : region_index > o.region_index;
      }
    };
    std::priority_queue<Head, std::vector<Head>, std::greater<>> heap;
    for (uint32_t i = 0; i < readers.size(); ++i) {
      if (const Record* r = readers[i]->peek()) heap.push({r->code, r->region_index, i});
    }
    while (!heap.empty()) {
      const uint32_t i = heap.top().reader;
      heap.pop();
      const Record* r = readers[i]->peek();
      out(*r);
      readers[i]->pop();
      if (const Record* next = readers[i]->peek()) heap.push({next->code, next->region_index, i});
      tick();
    }
    readers.clear();
    for (const Run& r : inputs) {
      fs::remove(r.path);
      if (usage) usage->release(r.bytes);
    }
  }

  void drain(const std::function<void(const Surfel&, uint64_t)>& emit, const std::function<void(float)>& progress) {
    if (drained) throw InvalidArgument("surfel sorter: drain() called twice");
    drained = true;
    // Progress over all records every pass touches.
    uint64_t total = stats.surfels, done = 0, next_report = 0;
    auto tick = [&] {
      if (++done >= next_report && progress && total > 0) {
        progress(float(double(done) / double(total)));
        next_report = done + std::max<uint64_t>(total / 100, 1);
      }
    };

    // 1. Everything fitted in memory: no disk at all.
    if (runs.empty()) {
      tbb::parallel_sort(buffer.begin(), buffer.end());
      for (const Record& r : buffer) {
        emit(r.surfel(), r.code);
        tick();
      }
      std::vector<Record>().swap(buffer);
      return;
    }
    spill();
    std::vector<Record>().swap(buffer);  // the merge buffers take its place
    {
      std::deque<uint64_t> sizes;
      for (const Run& r : runs) sizes.push_back(r.records);
      while (sizes.size() > fan_in) {
        uint64_t merged = 0;
        for (uint32_t k = 0; k < fan_in; ++k) {
          merged += sizes.front();
          sizes.pop_front();
        }
        total += merged;
        sizes.push_back(merged);
      }
    }
    note_peak(uint64_t(std::min<size_t>(runs.size(), fan_in) + 1) * block_records * sizeof(Record) +
              RunCodec::scratch_bytes(codec->block_bytes()));

    // 2. Intermediate passes until one merge can take every run.
    while (runs.size() > fan_in) {
      std::vector<Run> inputs(runs.begin(), runs.begin() + fan_in);
      runs.erase(runs.begin(), runs.begin() + fan_in);
      Run out{next_run_path(), 0};
      {
        RunWriter w(out.path, sizeof(Record), *codec, usage);
        std::vector<Record> block;
        block.reserve(block_records);
        merge(inputs, [&](const Record& r) {
          block.push_back(r);
          if (block.size() == block_records) {
            w.write(bytes_of(block));
            block.clear();
          }
        }, tick);
        w.write(bytes_of(block));
        w.close();
        out.bytes = w.bytes();
        stats.run_bytes += w.bytes();
        for (const Run& r : inputs) out.records += r.records;
      }
      ++stats.merges;
      runs.push_back(std::move(out));
    }

    // 3. The last merge feeds the caller.
    std::vector<Run> inputs(runs.begin(), runs.end());
    runs.clear();
    merge(inputs, [&](const Record& r) { emit(r.surfel(), r.code); }, tick);
    ++stats.merges;
  }
};

SurfelSorter::SurfelSorter(const tree::MortonFrame& frame, uint64_t memory_bytes, fs::path run_dir,
                           uint32_t max_fan_in, StagingUsage* usage)
    : impl_(std::make_unique<Impl>(frame, memory_bytes, std::move(run_dir), max_fan_in, usage)) {}

SurfelSorter::~SurfelSorter() = default;

void SurfelSorter::add(std::span<const Surfel> surfels) { impl_->add(surfels); }

void SurfelSorter::drain(const std::function<void(const Surfel&, uint64_t)>& emit,
                         const std::function<void(float)>& progress) {
  impl_->drain(emit, progress);
}

const SortStats& SurfelSorter::stats() const { return impl_->stats; }

}  // namespace pbgi::storage
