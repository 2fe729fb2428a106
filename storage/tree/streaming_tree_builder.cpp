#include "storage/tree/streaming_tree_builder.h"

#include "common/errors.h"
#include "storage/format/format_version.h"
#include "storage/tree/leaf_quantizer.h"
#include "storage/tree/node_summary.h"
#include "storage/tree/page_records.h"

#include <algorithm>
#include <bit>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

namespace pbgi::tree {

namespace {

using storage::kLeafRecordBytes;
using storage::kLinkRecordBytes;
using storage::kPageOverheadBytes;
using storage::kShapeBytes;

constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();

// A node of the open part of the tree.
struct Pending {
  Node node;                    // summary; child_count, surfel_count
  uint32_t child[2] = {kNone, kNone};
  uint32_t page = kNone;        // written: the page whose root this node is
  uint64_t bytes = 0;           // on disk: its pending treelet, or its link if written
  uint64_t payload_bits = 0;    // stored payloads of its pending treelet (0 once written)
  uint32_t code_bits = 0;       // its own stored payload's size
  uint32_t height = 0;          // depth of its deepest leaf below it
  uint32_t levels = 0;          // levels of its pending treelet (0 once written)
  bool candidate = false;       // leaf not closed yet: `raw` holds its surfels
  std::vector<Surfel> raw;      // candidate surfels (capacity kept across reuse)
  storage::LeafFrame frame;     // closed leaf
  std::vector<uint8_t> records; // closed leaf: its surfel records
  std::vector<uint8_t> emission;   // closed leaf, compact records: its emitting surfels' entries
  std::vector<SurfelGloss> gloss;  // closed leaf with a glossy surfel: each surfel's lobe

  bool written() const { return page != kNone; }
};

// Level of the separator between consecutive keys (code, index): the
// highest differing bit of the 128-bit key code:index. Codes differ ->
// 64 + that bit of the codes; equal codes -> that bit of the indices.
inline int separator_level(uint64_t prev_code, uint64_t code, uint64_t index) {
  if (prev_code != code) return 64 + (63 - std::countl_zero(prev_code ^ code));
  return 63 - std::countl_zero((index - 1) ^ index);
}

// Separators between regions lie above every Morton and index level.
constexpr int kRegionLevel0 = 128;
inline int region_separator_level(uint32_t prev_region, uint32_t region) {
  return kRegionLevel0 + (31 - std::countl_zero(prev_region ^ region));
}

}  // namespace

struct StreamingTreeBuilder::Impl {
  const BuildOptions options;
  const uint64_t page_bytes;     // 0 = unbounded
  const uint64_t link_bytes;     // a link record and its payload
  // Levels the treelet of a pending node `height` levels above its deepest
  // leaf may span (BuildOptions::page_levels, upper_page_levels).
  uint32_t max_levels(uint32_t height) const {
    return height >= BuildOptions::kUpperPageHeight ? options.upper_page_levels : options.page_levels;
  }
  TreeletSink& sink;
  const NodePayloadSizer* sizer;  // null: derived payloads

  std::vector<Pending> arena;
  std::vector<uint32_t> free_nodes;
  struct Open {
    uint32_t node;
    int level;  // of the separator to its right
  };
  std::vector<Open> stack;
  uint32_t current = kNone;  // the subtree left of the next separator
  uint64_t prev_code = 0;
  uint32_t prev_region = 0;
  bool finished = false;

  StreamingTreeStats stats;
  uint64_t pending_bytes = 0;
  // Scratch.
  std::vector<Surfel> decoded;
  Treelet treelet;
  std::vector<uint32_t> visited;
  storage::SurfelRecords records = storage::SurfelRecords::kCompact;  // of options.leaf_format
  size_t record_bytes = 0;

  Impl(const BuildOptions& o, uint64_t pb, uint64_t lpb, TreeletSink& s, const NodePayloadSizer* z)
      : options(o), page_bytes(pb), link_bytes(kLinkRecordBytes + lpb), sink(s), sizer(z) {
    options.validate();
    records = storage::written_surfel_records(options.leaf_format);
    record_bytes = storage::surfel_record_bytes(records);
    treelet.records = records;
    if (page_bytes != 0 && page_bytes < storage::min_page_bytes(options.leaf_size, options.leaf_format)) {
      throw InvalidArgument("page of " + std::to_string(page_bytes) + " bytes cannot hold a leaf of " +
                            std::to_string(options.leaf_size) + " surfels");
    }
    // A stored payload is at most a float32 one plus its code word.
    constexpr uint64_t kMaxStoredPayload = storage::kMaxPayloadBytesPerNode + 8;
    if (sizer && page_bytes != 0 &&
        page_bytes < storage::min_page_bytes(options.leaf_size, options.leaf_format) + kMaxStoredPayload) {
      throw InvalidArgument("page of " + std::to_string(page_bytes) + " bytes cannot hold a leaf of " +
                            std::to_string(options.leaf_size) + " surfels and its stored payload");
    }
  }

  uint32_t alloc() {
    if (!free_nodes.empty()) {
      const uint32_t i = free_nodes.back();
      free_nodes.pop_back();
      return i;
    }
    arena.emplace_back();
    return static_cast<uint32_t>(arena.size() - 1);
  }

  void release(uint32_t i) {
    Pending& p = arena[i];
    p.node = Node{};
    p.child[0] = p.child[1] = kNone;
    p.page = kNone;
    p.bytes = 0;
    p.payload_bits = 0;
    p.code_bits = 0;
    p.height = 0;
    p.levels = 0;
    p.candidate = false;
    p.raw.clear();
    p.records.clear();
    p.emission.clear();
    p.gloss.clear();
    free_nodes.push_back(i);
  }

  // Sizes a complete node's stored payload (post-order); the node keeps its
  // exact payload for its parent and for the page writer's codec.
  void size_payload(Pending& p) {
    if (!sizer) return;
    p.code_bits = sizer->bits(p.node);
    p.payload_bits += p.code_bits;
  }

  // Memory a closed leaf holds until its page is written.
  static uint64_t leaf_bytes(const Pending& q) { return q.records.size() + q.emission.size(); }

  // Bytes of a pending treelet once written (its payload array included).
  static uint64_t disk_bytes(const Pending& q) { return q.bytes + (q.payload_bits + 7) / 8; }

  void note_pending(int64_t delta) {
    pending_bytes = uint64_t(int64_t(pending_bytes) + delta);
    stats.peak_pending_bytes = std::max(stats.peak_pending_bytes, pending_bytes);
  }

  uint32_t new_candidate(const Surfel& s) {
    const uint32_t i = alloc();
    Pending& p = arena[i];
    p.candidate = true;
    p.raw.push_back(s);
    note_pending(sizeof(Surfel));
    return i;
  }

  // Quantizes a candidate's surfels and computes its summary.
  void close_leaf(uint32_t i) {
    Pending& p = arena[i];
    const size_t n = p.raw.size();
    p.records.resize(n * record_bytes);
    decoded.resize(n);
    p.emission.clear();
    p.frame = quantize_leaf(records, p.raw, p.records.data(), decoded, p.emission);
    for (const Surfel& s : p.raw) {
      if (!s.gloss.glossy()) continue;
      p.gloss.resize(n);
      for (size_t k = 0; k < n; ++k) p.gloss[k] = p.raw[k].gloss;
      break;
    }
    summarize_leaf(decoded, p.frame, p.node, PayloadMode::kRounded, BoundsMode::kRounded);
    p.bytes = kShapeBytes + kLeafRecordBytes + n * record_bytes + p.emission.size();
    p.payload_bits = 0;
    size_payload(p);
    p.height = 0;
    p.levels = 1;
    p.candidate = false;
    note_pending(int64_t(p.records.size() + p.emission.size()) - int64_t(n * sizeof(Surfel)));
    p.raw.clear();
    ++stats.leaf_count;
    ++stats.node_count;
  }

  // The node over a (left) and b (right), both complete.
  uint32_t join(uint32_t a, uint32_t b) {
    {
      Pending& pa = arena[a];
      Pending& pb = arena[b];
      if (pa.candidate && pb.candidate && pa.raw.size() + pb.raw.size() <= options.leaf_size) {
        pa.raw.insert(pa.raw.end(), pb.raw.begin(), pb.raw.end());
        release(b);
        return a;
      }
    }
    if (arena[a].candidate) close_leaf(a);
    if (arena[b].candidate) close_leaf(b);
    const uint32_t n = alloc();  // may reallocate the arena: no references above
    Pending& p = arena[n];
    const Pending& pa = arena[a];
    const Pending& pb = arena[b];
    p.child[0] = a;
    p.child[1] = b;
    summarize_internal(pa.node, &pb.node, p.node, PayloadMode::kRounded, BoundsMode::kRounded);
    p.height = 1 + std::max(pa.height, pb.height);
    p.bytes = kShapeBytes + pa.bytes + pb.bytes;
    p.payload_bits = pa.payload_bits + pb.payload_bits;
    size_payload(p);
    p.levels = 1 + std::max(pa.levels, pb.levels);
    note_pending(kShapeBytes);
    ++stats.node_count;
    // Write pending children until the node's treelet fits a page: the
    // taller one while it has too many levels, else the larger one.
    auto too_big = [&] {
      const Pending& q = arena[n];
      return page_bytes != 0 && (disk_bytes(q) + kPageOverheadBytes > page_bytes || q.levels > max_levels(q.height));
    };
    while (too_big()) {
      const uint32_t c0 = arena[n].child[0], c1 = arena[n].child[1];
      const Pending &q0 = arena[c0], &q1 = arena[c1];
      uint32_t victim;
      if (q0.written() || q1.written()) {
        victim = q0.written() ? c1 : c0;
      } else if (arena[n].levels > max_levels(arena[n].height) && q0.levels != q1.levels) {
        victim = q0.levels > q1.levels ? c0 : c1;
      } else {
        victim = disk_bytes(q0) >= disk_bytes(q1) ? c0 : c1;
      }
      if (arena[victim].written()) {
        throw Error("internal: a node with two linked children does not fit a page");  // min_page_bytes
      }
      write_page(victim);
      arena[n].bytes = kShapeBytes + arena[c0].bytes + arena[c1].bytes;
      arena[n].payload_bits = arena[n].code_bits + arena[c0].payload_bits + arena[c1].payload_bits;
      arena[n].levels = 1 + std::max(arena[c0].levels, arena[c1].levels);
    }
    return n;
  }

  // Writes the pending treelet under `root` as the next page; `root` stays
  // as a written stub (its summary and page id) for its parent's link.
  uint32_t write_page(uint32_t root) {
    treelet.clear();
    visited.clear();
    // Same recursion as expand_treelet(): node, then all of child 0 (or its
    // link), then all of child 1.
    struct Frame {
      uint32_t node;
      uint32_t slot;
    };
    std::vector<Frame> stack_frames;
    auto emit = [&](uint32_t i) {
      Pending& p = arena[i];
      storage::NodeShape shape;
      shape.child_count = static_cast<uint8_t>(p.node.child_count);
      for (uint32_t c = 0; c < p.node.child_count; ++c) shape.external[c] = arena[p.child[c]].written();
      treelet.shapes.push_back(storage::encode_shape(shape));
      if (sizer) treelet.nodes.push_back(p.node);
      if (p.node.child_count == 0) {
        const size_t at = treelet.leaf_records.size();
        treelet.leaf_records.resize(at + kLeafRecordBytes);
        storage::write_leaf_record(p.frame, p.node.surfel_count, treelet.leaf_records.data() + at);
        const size_t before = treelet.surfel_records.size() / record_bytes;
        treelet.surfel_records.insert(treelet.surfel_records.end(), p.records.begin(), p.records.end());
        treelet.emission.insert(treelet.emission.end(), p.emission.begin(), p.emission.end());
        if (!p.gloss.empty()) {
          // Lobes are listed per surfel of the page once one leaf has any.
          treelet.gloss.resize(before);
          treelet.gloss.insert(treelet.gloss.end(), p.gloss.begin(), p.gloss.end());
        }
      } else {
        stack_frames.push_back({i, 0});
      }
      if (i != root) visited.push_back(i);
    };
    emit(root);
    while (!stack_frames.empty()) {
      Frame& f = stack_frames.back();
      const Pending& p = arena[f.node];
      if (f.slot == p.node.child_count) {
        stack_frames.pop_back();
        continue;
      }
      const uint32_t c = p.child[f.slot++];
      if (arena[c].written()) {
        treelet.links.push_back({arena[c].page, arena[c].node});
        visited.push_back(c);
      } else {
        emit(c);  // may grow stack_frames: `f` is not used after this
      }
    }
    if (!treelet.gloss.empty()) treelet.gloss.resize(treelet.surfel_records.size() / record_bytes);
    const uint32_t id = sink.write(treelet);
    if (id != stats.page_count) {
      throw Error("internal: page sink returned id " + std::to_string(id) + ", expected " +
                  std::to_string(stats.page_count));
    }
    ++stats.page_count;
    // Free what the page now holds; the root becomes a stub.
    int64_t freed = 0;
    for (uint32_t i : visited) {
      if (!arena[i].written()) freed += int64_t(arena[i].node.child_count == 0 ? leaf_bytes(arena[i]) : kShapeBytes);
      release(i);
    }
    Pending& r = arena[root];
    freed += int64_t(r.node.child_count == 0 ? leaf_bytes(r) : kShapeBytes);
    note_pending(-freed);
    r.page = id;
    r.bytes = link_bytes;
    r.payload_bits = 0;
    r.levels = 0;
    r.child[0] = r.child[1] = kNone;
    r.records.clear();
    r.emission.clear();
    r.gloss.clear();
    return id;
  }

  // `current` is the whole subtree of prev_region: it becomes a page of
  // its own, the region's root.
  void close_region() {
    if (page_bytes == 0) throw InvalidArgument("tree builder: several air regions need pages (page_bytes > 0)");
    if (arena[current].candidate) close_leaf(current);
    if (!arena[current].written()) write_page(current);
    stats.region_roots.push_back({prev_region, {arena[current].page, 0}});
  }

  void add(const Surfel& s, uint64_t code) {
    if (finished) throw InvalidArgument("tree builder: add() after finish()");
    const uint64_t index = stats.surfel_count;
    if (index > 0 && (s.region < prev_region || (s.region == prev_region && code < prev_code))) {
      throw InvalidArgument("tree builder: surfel " + std::to_string(index) + " has region " +
                            std::to_string(s.region) + " and Morton code " + std::to_string(code) +
                            ", below its predecessor's " + std::to_string(prev_region) + " and " +
                            std::to_string(prev_code) + " (the stream must be sorted)");
    }
    constexpr uint64_t kMaxSurfels = uint64_t(1) << 40;
    if (index >= kMaxSurfels) throw InvalidArgument("tree builder: more than 2^40 surfels");
    const uint32_t leaf = new_candidate(s);
    if (index > 0) {
      const bool new_region = s.region != prev_region;
      const int level =
          new_region ? region_separator_level(prev_region, s.region) : separator_level(prev_code, code, index);
      // A new region closes every open subtree of the previous one first
      // (their separators lie below any region's).
      while (!stack.empty() && stack.back().level < std::min(level, kRegionLevel0)) {
        const uint32_t left = stack.back().node;
        stack.pop_back();
        current = join(left, current);
      }
      if (new_region) close_region();
      while (!stack.empty() && stack.back().level < level) {
        const uint32_t left = stack.back().node;
        stack.pop_back();
        current = join(left, current);
      }
      stack.push_back({current, level});
    }
    current = leaf;
    prev_code = code;
    prev_region = s.region;
    ++stats.surfel_count;
  }

  StreamingTreeStats finish() {
    if (finished) throw InvalidArgument("tree builder: finish() called twice");
    finished = true;
    if (stats.surfel_count == 0) throw InvalidArgument("cannot build a tree over 0 surfels");
    if (!stats.region_roots.empty()) {
      // The last region's subtree, as add() closes the others.
      while (!stack.empty() && stack.back().level < kRegionLevel0) {
        const uint32_t left = stack.back().node;
        stack.pop_back();
        current = join(left, current);
      }
      close_region();
    }
    while (!stack.empty()) {
      const uint32_t left = stack.back().node;
      stack.pop_back();
      current = join(left, current);
    }
    if (arena[current].candidate) close_leaf(current);
    stats.max_depth = arena[current].height;
    const uint32_t page = write_page(current);
    stats.root = {page, 0};
    return stats;
  }
};

StreamingTreeBuilder::StreamingTreeBuilder(const BuildOptions& options, uint64_t page_bytes,
                                           uint64_t link_payload_bytes, TreeletSink& sink,
                                           const NodePayloadSizer* sizer)
    : impl_(std::make_unique<Impl>(options, page_bytes, link_payload_bytes, sink, sizer)) {}

StreamingTreeBuilder::~StreamingTreeBuilder() = default;

void StreamingTreeBuilder::add(const Surfel& s, uint64_t code) { impl_->add(s, code); }

StreamingTreeStats StreamingTreeBuilder::finish() { return impl_->finish(); }

}  // namespace pbgi::tree
