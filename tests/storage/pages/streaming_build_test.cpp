// The streaming build: external sort under a memory bound, equality with
// the in-memory build, independence from batch sizes and sort memory.
#include "common/errors.h"
#include "storage/cache/page_cache.h"
#include "storage/codecs/payload_codec.h"
#include "storage/pages/page_encoding.h"
#include "storage/pages/page_set.h"
#include "storage/pages/surfel_sorter.h"
#include "storage/tree/memory_tree.h"
#include "storage/tree/morton.h"
#include "storage/tree/streaming_tree_builder.h"
#include "storage/tree/tree_builder.h"
#include "tests/storage/pages/temp_dir.h"
#include "tests/storage/pages/tree_walk.h"
#include "tests/storage/tree/random_surfels.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <random>

namespace pbgi::storage {
namespace {

namespace fs = std::filesystem;

std::vector<uint8_t> read_file(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), {}};
}

// Adds `surfels` to `b` in batches of random sizes (1 to 3000).
void add_in_random_batches(PageSetBuilder& b, const std::vector<Surfel>& surfels, uint32_t seed) {
  std::mt19937 rng(seed);
  for (size_t at = 0; at < surfels.size();) {
    const size_t n = std::min<size_t>(surfels.size() - at, 1 + rng() % 3000);
    b.add({surfels.data() + at, n});
    at += n;
  }
}

TEST(StreamingBuild, EqualsTheInMemoryBuildWithinItsMemoryBound) {
  test::TempDir tmp;
  const std::vector<Surfel> surfels = test::random_surfels(60000, 31);
  tree::BuildOptions o;
  o.page_size = 16384;
  o.sort_memory_bytes = 64 * 1024;  // ~800 surfels per run: ~75 runs, two merges

  PageSetBuilder b(o, "stream", tmp.path() / "small", tree::surfel_bounds(surfels));
  add_in_random_batches(b, surfels, 1);
  const Manifest m = b.finish();
  const BuildReport& r = b.report();
  EXPECT_EQ(r.surfels, surfels.size());
  EXPECT_GT(r.runs, 64u);        // more runs than one merge takes
  EXPECT_GE(r.merges, 2u);       // so an intermediate merge happened
  EXPECT_GT(r.sort_peak_bytes, 0u);
  EXPECT_LE(r.sort_peak_bytes, o.sort_memory_bytes);  // the bound held
  EXPECT_LT(r.tree_peak_pending_bytes, 64u * o.page_size);
  EXPECT_EQ(m.stats.surfel_count, surfels.size());

  // Same traversal, node for node and surfel for surfel, as the tree built
  // in memory from the same surfels.
  PageSetReader reader(tmp.path() / "small", std::make_shared<PageCache>(uint64_t(1) << 30));
  test::expect_same_walk(test::walk(reader), test::walk(tree::MemoryTree(tree::build_tree(surfels, o))));

  // The sort memory and the batches change nothing: same bytes on disk.
  tree::BuildOptions big = o;
  big.sort_memory_bytes = uint64_t(64) << 20;  // one run, sorted in memory
  BuildReport r2;
  build_page_set(surfels, big, "stream", tmp.path() / "big", {}, &r2);
  EXPECT_EQ(r2.runs, 0u);
  EXPECT_EQ(read_file(tmp.path() / "small" / kPagesFileName), read_file(tmp.path() / "big" / kPagesFileName));
  EXPECT_EQ(read_file(tmp.path() / "small" / kManifestFileName), read_file(tmp.path() / "big" / kManifestFileName));
  // Run files went away with the build.
  for (const auto& e : fs::directory_iterator(tmp.path())) EXPECT_TRUE(fs::is_directory(e)) << e.path();
  for (const auto& e : fs::recursive_directory_iterator(tmp.path()))
    EXPECT_EQ(e.path().string().find("run-"), std::string::npos) << e.path();
}

TEST(StreamingBuild, InvalidSurfelNamedByArrivalIndex) {
  test::TempDir tmp;
  std::vector<Surfel> surfels = test::random_surfels(5000, 2);
  surfels[4321].radius = std::numeric_limits<float>::infinity();
  PageSetBuilder b({}, "k", tmp.path() / "s", tree::surfel_bounds(surfels));
  try {
    add_in_random_batches(b, surfels, 3);
    FAIL() << "invalid surfel accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("surfel 4321"), std::string::npos) << e.what();
  }
}

TEST(StreamingBuild, SurfelsOutsideTheBoundsAreStillStored) {
  // The bounds only order the surfels; one far outside is clamped in the
  // order and stored as it is.
  test::TempDir tmp;
  std::vector<Surfel> surfels = test::random_surfels(2000, 4);
  surfels[10].position = {1e4f, -1e4f, 3e3f};
  Imath::Box3f small({-1, -1, -1}, {1, 1, 1});
  PageSetBuilder b({}, "k", tmp.path() / "s", small);
  b.add(surfels);
  b.finish();
  PageSetReader reader(tmp.path() / "s", std::make_shared<PageCache>(uint64_t(1) << 30));
  const test::Walk w = test::walk(reader);
  ASSERT_EQ(w.surfels.size(), surfels.size());
  EXPECT_TRUE(std::any_of(w.surfels.begin(), w.surfels.end(),
                          [](const Surfel& s) { return std::abs(s.position.x - 1e4f) < 1.f; }));
}

TEST(SurfelSorter, SortsByCodeThenArrivalWithinItsMemory) {
  test::TempDir tmp;
  std::vector<Surfel> surfels = test::random_surfels(9000, 6);
  // Duplicated positions: ties must keep arrival order.
  for (size_t i = 0; i < surfels.size(); i += 7) surfels[i].position = surfels[0].position;
  // Glossy lobes travel with their surfels through the runs.
  for (size_t i = 0; i < surfels.size(); i += 3) surfels[i].gloss = {0.01f * float(i % 50 + 1), {0.9f, 0.5f, 0.1f}};
  const tree::MortonFrame frame(tree::surfel_bounds(surfels));
  constexpr uint64_t kMemory = 64 * 1024;
  SurfelSorter sorter(frame, kMemory, tmp.path(), /*max_fan_in=*/2);
  for (size_t at = 0; at < surfels.size(); at += 1000) sorter.add({surfels.data() + at, 1000});

  std::vector<std::pair<uint64_t, size_t>> want;
  for (size_t i = 0; i < surfels.size(); ++i) want.push_back({frame.code(surfels[i].position), i});
  std::sort(want.begin(), want.end());

  std::vector<float> progress;
  size_t k = 0;
  sorter.drain(
      [&](const Surfel& s, uint64_t code) {
        ASSERT_LT(k, want.size());
        ASSERT_EQ(code, want[k].first) << k;
        ASSERT_TRUE(test::same_surfel(s, surfels[want[k].second])) << k;
        ++k;
      },
      [&](float f) { progress.push_back(f); });
  EXPECT_EQ(k, surfels.size());
  const SortStats& st = sorter.stats();
  // 9000 surfels, 294 96-byte records per run: 64 KiB less the codec's
  // scratch (4 compressed blocks of 96 records, run_file.h).
  EXPECT_EQ(st.runs, 31u);
  EXPECT_EQ(st.merges, 30u);  // pairwise: 31 runs -> 1
  EXPECT_LE(st.peak_bytes, kMemory);
  EXPECT_TRUE(fs::is_empty(tmp.path()));  // every run file deleted
  ASSERT_FALSE(progress.empty());
  EXPECT_TRUE(std::is_sorted(progress.begin(), progress.end()));
  EXPECT_LE(progress.back(), 1.f);
  EXPECT_GT(progress.back(), 0.99f);
}

TEST(SurfelSorter, RunsOfSurfacesAreCompressed) {
  // A surface sampled on a grid, as a scene's surfels are: one normal, one
  // albedo, near positions. Its runs take a fraction of their records.
  test::TempDir tmp;
  std::vector<Surfel> surfels;
  for (int i = 0; i < 200; ++i) {
    for (int j = 0; j < 100; ++j) {
      Surfel s;
      s.position = {0.01f * float(i), 0.5f, 0.01f * float(j)};
      s.normal = {0, 1, 0};
      s.radius = 0.006f;
      s.albedo = {0.7f, 0.6f, 0.5f};
      s.radiance = {0.1f + 0.001f * float(i), 0.2f, 0.3f + 0.002f * float(j)};
      surfels.push_back(s);
    }
  }
  SurfelSorter sorter(tree::MortonFrame(tree::surfel_bounds(surfels)), uint64_t(256) * 1024, tmp.path());
  sorter.add(surfels);
  size_t n = 0;
  sorter.drain([&](const Surfel&, uint64_t) { ++n; });
  EXPECT_EQ(n, surfels.size());
  const SortStats& st = sorter.stats();
  EXPECT_GT(st.runs, 5u);
  EXPECT_LT(st.run_bytes, surfels.size() * 96 / 3) << st.run_bytes;
}

TEST(SurfelSorter, DamagedRunIsCorruption) {
  test::TempDir tmp;
  const std::vector<Surfel> surfels = test::random_surfels(3000, 9);
  SurfelSorter sorter(tree::MortonFrame(tree::surfel_bounds(surfels)), 64 * 1024, tmp.path());
  sorter.add(surfels);
  // Flip a byte in the middle of the first run.
  const fs::path run = tmp.path() / "run-000000.tmp";
  ASSERT_TRUE(fs::exists(run));
  {
    std::fstream f(run, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(1000);
    char c = 0;
    f.read(&c, 1);
    c ^= 0x40;
    f.seekp(1000);
    f.write(&c, 1);
  }
  try {
    sorter.drain([](const Surfel&, uint64_t) {});
    FAIL() << "a damaged run was merged";
  } catch (const CorruptionError& e) {
    EXPECT_NE(std::string(e.what()).find(run.string() + ": run block at offset"), std::string::npos) << e.what();
  }
}

TEST(StreamingTreeBuilder, RefusesUnsortedCodesAndEmptyStreams) {
  struct NullSink final : tree::TreeletSink {
    uint32_t write(const tree::Treelet&) override { return n++; }
    uint32_t n = 0;
  } sink;
  tree::StreamingTreeBuilder b({}, 65536, 144, sink);
  const Surfel s = test::random_surfels(1)[0];
  b.add(s, 10);
  b.add(s, 10);
  EXPECT_THROW(b.add(s, 9), InvalidArgument);
  tree::StreamingTreeBuilder empty({}, 65536, 144, sink);
  EXPECT_THROW(empty.finish(), InvalidArgument);
}

// Height (levels above its deepest leaf, across pages) and levels within
// its page of the node at shapes[at] of treelet t, whose linked children's
// pages have the heights `page_height`. Advances `at` and `link` past the
// node's subtree in the page, in the parse order of FORMAT.md.
struct NodeShape {
  uint32_t height = 0, levels = 1;
};
NodeShape shape_of(const tree::Treelet& t, size_t& at, size_t& link, const std::vector<uint32_t>& page_height) {
  const uint8_t shape = t.shapes.at(at++);
  NodeShape out;
  for (uint32_t c = 0; c < (shape & 3u); ++c) {
    if (shape & (4u << c)) {
      out.height = std::max(out.height, 1 + page_height.at(t.links.at(link++).page));
    } else {
      const NodeShape child = shape_of(t, at, link, page_height);
      out.height = std::max(out.height, 1 + child.height);
      out.levels = std::max(out.levels, 1 + child.levels);
    }
  }
  return out;
}

struct KeepTreelets final : tree::TreeletSink {
  uint32_t write(const tree::Treelet& t) override {
    treelets.push_back(t);
    return uint32_t(treelets.size() - 1);
  }
  std::vector<tree::Treelet> treelets;
};

tree::StreamingTreeStats build_treelets(const tree::BuildOptions& o, uint64_t page_bytes,
                                        const std::vector<Surfel>& surfels, KeepTreelets& sink) {
  tree::StreamingTreeBuilder b(o, page_bytes, 144, sink);
  std::vector<std::pair<uint64_t, size_t>> order;
  const tree::MortonFrame frame(tree::surfel_bounds(surfels));
  for (size_t i = 0; i < surfels.size(); ++i) order.push_back({frame.code(surfels[i].position), i});
  std::sort(order.begin(), order.end());
  for (const auto& [code, i] : order) b.add(surfels[i], code);
  return b.finish();
}

// A page holds at most page_levels levels of the tree, or upper_page_levels
// when its root lies kUpperPageHeight or more levels above its deepest leaf
// (build_options.h): the builder cuts pages so, with the defaults and with
// other values, and the upper rule is used (some pages are taller than
// page_levels).
TEST(StreamingTreeBuilder, PagesSpanThePageLevelsNearTheLeavesAndTheUpperLevelsAbove) {
  const std::vector<Surfel> surfels = test::random_surfels(20000, 7);
  for (const auto& [lower, upper] :
       {std::pair<uint32_t, uint32_t>{tree::BuildOptions{}.page_levels, tree::BuildOptions{}.upper_page_levels},
        {2, 7},
        {5, 5}}) {
    SCOPED_TRACE(std::to_string(lower) + " / " + std::to_string(upper) + " levels");
    tree::BuildOptions o;
    o.leaf_size = 1;
    o.page_levels = lower;
    o.upper_page_levels = upper;
    KeepTreelets sink;
    const tree::StreamingTreeStats stats = build_treelets(o, 65536, surfels, sink);
    EXPECT_GT(stats.max_depth, 2 * upper);
    std::vector<uint32_t> page_height;
    uint32_t tallest = 0, tallest_lower = 0;
    for (uint32_t id = 0; id < sink.treelets.size(); ++id) {
      size_t at = 0, link = 0;
      const NodeShape root = shape_of(sink.treelets[id], at, link, page_height);
      ASSERT_EQ(at, sink.treelets[id].shapes.size());
      page_height.push_back(root.height);
      const bool upper_page = root.height >= tree::BuildOptions::kUpperPageHeight;
      EXPECT_LE(root.levels, upper_page ? upper : lower) << "page " << id << ", height " << root.height;
      tallest = std::max(tallest, root.levels);
      if (!upper_page) tallest_lower = std::max(tallest_lower, root.levels);
    }
    EXPECT_EQ(tallest_lower, lower);
    EXPECT_EQ(tallest, upper);
  }
}

// A reader refuses a page whose treelet is deeper than kMaxPageLevels
// (here the whole tree as one treelet) as corruption naming the page, and
// reads the pages the builder cut.
TEST(StreamingTreeBuilder, AReaderRefusesAPageDeeperThanTheFormatAllows) {
  const std::vector<Surfel> surfels = test::random_surfels(20000, 7);
  tree::BuildOptions o;
  o.leaf_size = 1;
  const auto codec = make_payload_codec(0);
  KeepTreelets paged;
  const tree::StreamingTreeStats stats = build_treelets(o, 65536, surfels, paged);
  EXPECT_GT(stats.max_depth, kMaxPageLevels);
  std::vector<uint8_t> bytes;
  for (uint32_t id = 0; id < paged.treelets.size(); ++id) {
    encode_page(paged.treelets[id], id, *codec, bytes);
    EXPECT_NO_THROW(decode_page(bytes, {"p", id, 0}, kPageFormatCurrent, *codec, stats.page_count));
  }
  KeepTreelets whole;
  build_treelets(o, 0, surfels, whole);  // one unbounded treelet
  ASSERT_EQ(whole.treelets.size(), 1u);
  encode_page(whole.treelets[0], 0, *codec, bytes);
  try {
    decode_page(bytes, {"/x/pages.pbgp", 0, 0}, kPageFormatCurrent, *codec, 1);
    FAIL() << "a treelet deeper than the page levels was accepted";
  } catch (const CorruptionError& e) {
    EXPECT_NE(std::string(e.what()).find("levels deep"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("page 0"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace pbgi::storage
