// Page sets end to end: build, publish, read back through the cache, and
// refuse damaged or foreign files.
#include "storage/pages/page_set.h"
#include "common/errors.h"
#include "storage/cache/page_cache.h"
#include "storage/codecs/payload_codec.h"
#include "storage/format/manifest_frame.h"
#include "storage/format/page_frame.h"
#include "storage/pages/manifest_file.h"
#include "storage/pages/page_set_inspection.h"
#include "storage/tree/memory_tree.h"
#include "storage/tree/tree_builder.h"
#include "tests/storage/pages/file_bytes.h"
#include "tests/storage/pages/temp_dir.h"
#include "tests/storage/pages/tree_walk.h"
#include "tests/storage/tree/random_surfels.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>

#include <fstream>
#include <map>
#include <thread>

namespace pbgi::storage {
namespace {

namespace fs = std::filesystem;

using test::read_file;
using test::write_file;
bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

std::vector<fs::path> leftovers(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (contains(e.path().filename().string(), ".tmp-")) out.push_back(e.path());
  return out;
}

class PageSetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    surfels_ = test::random_surfels(3000, 11);
    options_.leaf_size = 4;
    options_.page_size = 4096;  // small pages: many of them
    dir_ = tmp_.path() / "set";
    manifest_ = build_page_set(surfels_, options_, "key-123", dir_);
  }
  test::TempDir tmp_;
  std::vector<Surfel> surfels_;
  tree::BuildOptions options_;
  fs::path dir_;
  Manifest manifest_;
};

TEST_F(PageSetTest, RoundTripEqualsTheBuiltTree) {
  const tree::BuiltTree built = tree::build_tree(surfels_, options_);
  const tree::MemoryTree memory(built);
  auto cache = std::make_shared<PageCache>(uint64_t(1) << 30);
  PageSetReader reader(dir_, cache);

  // Manifest as returned and as read.
  const Manifest& m = reader.manifest();
  EXPECT_EQ(m.build_key, "key-123");
  EXPECT_EQ(m.options.leaf_size, 4u);
  EXPECT_EQ(m.options.page_size, 4096u);
  EXPECT_EQ(m.codec, 0u);
  EXPECT_EQ(m.page_format, kPageFormatCurrent);
  // Pages are written bottom-up: the root's page is the last.
  EXPECT_EQ(m.root, (tree::NodeRef{m.stats.page_count - 1, 0}));
  EXPECT_EQ(m.pages, manifest_.pages);
  EXPECT_EQ(m.stats.surfel_count, 3000u);
  EXPECT_EQ(m.stats.node_count, built.nodes.size());
  EXPECT_EQ(m.stats.leaf_count, built.leaf_count);
  EXPECT_EQ(m.stats.max_depth, built.max_depth);
  EXPECT_EQ(m.stats.page_count, m.pages.size());
  EXPECT_EQ(m.stats.file_bytes, fs::file_size(dir_ / kPagesFileName));
  EXPECT_GT(m.stats.page_count, 15u);

  // Every node and surfel, reached from the root across pages.
  const test::Walk want = test::walk(memory);
  const test::Walk got = test::walk(reader);
  test::expect_same_walk(got, want);
  EXPECT_EQ(got.pages.size(), m.stats.page_count);  // every page is reachable

  // Pages respect the size limit and are connected subtrees: entered only
  // at their root (index 0), from exactly one parent in a later page.
  std::map<uint32_t, int> entries;
  const uint32_t root_page = m.stats.page_count - 1;
  for (uint32_t p = 0; p < m.stats.page_count; ++p) {
    EXPECT_LE(m.pages[p].bytes, options_.page_size);
    const tree::PagePtr page = reader.page(p);
    EXPECT_EQ(page->id, p);
    for (const tree::Node& n : page->nodes) {
      for (uint32_t c = 0; c < n.child_count; ++c) {
        if (n.children[c].page != p) {
          EXPECT_EQ(n.children[c].index, 0u);
          EXPECT_LT(n.children[c].page, p);
          entries[n.children[c].page]++;
        }
      }
    }
  }
  for (uint32_t p = 0; p < root_page; ++p) EXPECT_EQ(entries[p], 1) << "page " << p;
  EXPECT_EQ(entries.count(root_page), 0u);
}

// Surfels of few albedos (one per cluster of space, as walls have): most
// pages store their albedo once (V8: an albedo column of width 0 in the
// surfel section), and the page set still equals the in-memory tree bit
// for bit.
TEST_F(PageSetTest, SharedAlbedoPagesEqualTheInMemoryTree) {
  std::vector<Surfel> surfels = surfels_;
  for (Surfel& s : surfels) s.albedo = s.position.x < 0.f ? Imath::C3f(0.7f, 0.2f, 0.2f) : Imath::C3f(0.5f);
  const fs::path dir = tmp_.path() / "shared";
  const Manifest m = build_page_set(surfels, options_, "key-shared", dir);
  const tree::MemoryTree memory(tree::build_tree(surfels, options_));
  PageSetReader reader(dir, nullptr);
  test::expect_same_walk(test::walk(reader), test::walk(memory));
  // Smaller than the same surfels with random albedos (~3 bytes a surfel
  // here, of the 27 bits random albedo mantissas take in a column).
  EXPECT_LT(m.stats.file_bytes + 2 * surfels.size(), manifest_.stats.file_bytes);
  // V8 pages never carry V6's shared-albedo flag.
  const auto bytes = read_file(dir / kPagesFileName);
  for (const PageExtent& e : m.pages)
    EXPECT_EQ(read_page_header(bytes.data() + e.offset).flags & kPageFlagSharedAlbedo, 0u);
}

TEST_F(PageSetTest, InspectionAgreesWithTheManifest) {
  PageSetReader reader(dir_, std::make_shared<PageCache>(uint64_t(1) << 30));
  const PageSetInspection r = inspect_page_set(reader);
  EXPECT_TRUE(r.walked);
  EXPECT_TRUE(r.consistent);
  EXPECT_EQ(r.nodes, manifest_.stats.node_count);
  EXPECT_EQ(r.surfels, 3000u);
  EXPECT_EQ(r.pages_reached, manifest_.stats.page_count);
  EXPECT_EQ(r.leaf_depth_max, manifest_.stats.max_depth);
  EXPECT_LE(r.leaf_depth_min, r.leaf_depth_max);
  EXPECT_GE(r.path_pages_max, 2u);
  EXPECT_GT(r.fill_min, 0.0);
  EXPECT_LE(r.fill_max, 1.0);
  EXPECT_EQ(r.payload_bytes_per_node, 0u);  // derived at load
  EXPECT_EQ(r.surfel_record_bytes, 18u);    // compact records, before packing
  // V8 pages: shapes in nibbles, leaves, surfels and link payloads packed.
  EXPECT_TRUE(r.packed_sections);
  EXPECT_EQ(r.topology_bytes_per_node, 0.5);
  EXPECT_EQ(r.leaf_record_bytes, 0u);
  EXPECT_EQ(r.link_payload_bytes, 0u);
  // 18-byte surfels (and 4 bytes per emitting one: a tenth here), leaf
  // records, and per page of a few levels a frame, a table
  // entry and its parent's link with a 76-byte payload (FORMAT.md, "Why
  // this layout"): ~40 bytes per surfel here.
  EXPECT_LT(double(manifest_.stats.file_bytes) / manifest_.stats.surfel_count, 48.0);
  const PageSetInspection quick = inspect_page_set(reader, false);
  EXPECT_FALSE(quick.walked);
  EXPECT_EQ(quick.fill_mean, r.fill_mean);
}

TEST_F(PageSetTest, FlippedPageByteIsCorruptionNamingThePage) {
  const fs::path pages = dir_ / kPagesFileName;
  const auto good = read_file(pages);
  const uint32_t victims[] = {0, 5, manifest_.stats.page_count - 1};
  for (uint32_t victim : victims) {
    const PageExtent e = manifest_.pages[victim];
    // Header, topology, somewhere in the middle, last surfel byte, trailer.
    for (uint64_t at :
         {uint64_t(2), uint64_t(40), uint64_t(e.bytes / 2), uint64_t(e.bytes - 9), uint64_t(e.bytes - 1)}) {
      auto bad = good;
      bad[e.offset + at] ^= 0x04;
      write_file(pages, bad);
      auto cache = std::make_shared<PageCache>(uint64_t(1) << 30);
      PageSetReader reader(dir_, cache);
      for (int attempt = 0; attempt < 2; ++attempt) {  // a failed load is not cached
        try {
          reader.page(victim);
          FAIL() << "damage at page " << victim << " + " << at << " not detected";
        } catch (const CorruptionError& err) {
          const std::string msg = err.what();
          EXPECT_TRUE(contains(msg, "page " + std::to_string(victim) + " ")) << msg;
          EXPECT_TRUE(contains(msg, "pages.pbgp")) << msg;
          EXPECT_TRUE(contains(msg, "offset " + std::to_string(e.offset))) << msg;
        }
      }
      // The other pages are still served.
      const uint32_t other = victim == 0 ? 1 : 0;
      EXPECT_NO_THROW(reader.page(other));
    }
  }
  write_file(pages, good);
  PageSetReader reader(dir_, nullptr);
  EXPECT_NO_THROW(test::walk(reader));
}

TEST_F(PageSetTest, FlippedManifestByteIsRefused) {
  const fs::path path = dir_ / kManifestFileName;
  const auto good = read_file(path);
  // Every byte, in memory (decode_manifest is what the reader runs).
  for (size_t i = 0; i < good.size(); ++i) {
    auto bad = good;
    bad[i] ^= 0x20;
    try {
      decode_manifest(bad, path.string());
      FAIL() << "damage at manifest byte " << i << " not detected";
    } catch (const VersionError&) {
      EXPECT_TRUE(i >= 4 && i < 8) << "byte " << i;  // the version field itself
    } catch (const CorruptionError& e) {
      EXPECT_TRUE(contains(e.what(), "manifest.pbgm")) << e.what();
    }
  }
  // A few through the files and the reader.
  for (size_t i : {size_t(0), size_t(20), good.size() / 2, good.size() - 1}) {
    auto bad = good;
    bad[i] ^= 0x20;
    write_file(path, bad);
    EXPECT_THROW(PageSetReader(dir_, nullptr), CorruptionError) << "byte " << i;
  }
  write_file(path, good);
  EXPECT_NO_THROW(PageSetReader(dir_, nullptr));
}

TEST_F(PageSetTest, UnknownVersionsAreVersionErrors) {
  const fs::path path = dir_ / kManifestFileName;
  const auto good = read_file(path);

  // A whole manifest of a newer format, correctly checksummed.
  const ManifestBody body = unframe_manifest(good, "m");
  write_file(path, frame_manifest(body.body, kManifestFormatLatest + 1));
  EXPECT_THROW(PageSetReader(dir_, nullptr), VersionError);

  // A current manifest that declares pages of a newer format.
  Manifest m = decode_manifest(good, "m");
  m.page_format = 99;  // unknown to this build
  write_file(path, encode_manifest(m));
  EXPECT_THROW(PageSetReader(dir_, nullptr), VersionError);

  // ... or of a retired format (before cut-shaped treelets): rebuilt.
  for (const uint32_t retired : {kPageFormatV2, kPageFormatV3}) {
    m = decode_manifest(good, "m");
    m.page_format = retired;
    write_file(path, encode_manifest(m));
    try {
      PageSetReader r(dir_, nullptr);
      FAIL() << "page format " << retired << " accepted";
    } catch (const VersionError& e) {
      EXPECT_TRUE(contains(e.what(), "rebuild")) << e.what();
    }
  }

  // ... or an unknown payload codec.
  m = decode_manifest(good, "m");
  m.codec = 200;
  write_file(path, encode_manifest(m));
  EXPECT_THROW(PageSetReader(dir_, nullptr), VersionError);
  write_file(path, good);

  // A page of a newer format (correctly sealed) inside a current page set.
  const fs::path pages = dir_ / kPagesFileName;
  auto bytes = read_file(pages);
  const PageExtent e = manifest_.pages[3];
  std::span<uint8_t> page(bytes.data() + e.offset, e.bytes);
  PageHeader h = read_page_header(page.data());
  h.format_version = 99;  // unknown to this build
  write_page_header(h, page.data());
  seal_page(page);
  write_file(pages, bytes);
  PageSetReader reader(dir_, nullptr);
  EXPECT_THROW(reader.page(3), VersionError);
  EXPECT_NO_THROW(reader.page(2));
}

TEST_F(PageSetTest, TruncatedOrMissingFilesAreRefused) {
  const fs::path pages = dir_ / kPagesFileName;
  auto bytes = read_file(pages);
  bytes.resize(bytes.size() - 100);
  write_file(pages, bytes);
  EXPECT_THROW(PageSetReader(dir_, nullptr), CorruptionError);
  EXPECT_THROW(PageSetReader(tmp_.path() / "nothing-here", nullptr), NotFound);
  fs::remove(pages);
  EXPECT_THROW(PageSetReader(dir_, nullptr), NotFound);
}

TEST_F(PageSetTest, PageIdOutOfRange) {
  PageSetReader reader(dir_, nullptr);
  EXPECT_THROW(reader.page(manifest_.stats.page_count), InvalidArgument);
}

TEST_F(PageSetTest, PublishIsAtomic) {
  // An existing directory is refused and left as it was.
  const auto before = read_file(dir_ / kManifestFileName);
  EXPECT_THROW(build_page_set(surfels_, options_, "other", dir_), InvalidArgument);
  EXPECT_EQ(read_file(dir_ / kManifestFileName), before);
  // Also an empty one (rename() alone would replace it).
  fs::create_directory(tmp_.path() / "empty");
  EXPECT_THROW(build_page_set(surfels_, options_, "k", tmp_.path() / "empty"), InvalidArgument);
  EXPECT_TRUE(fs::is_empty(tmp_.path() / "empty"));
  // A missing parent is refused.
  EXPECT_THROW(build_page_set(surfels_, options_, "k", tmp_.path() / "no" / "set"), InvalidArgument);

  // A build cancelled half way (progress throws) leaves nothing behind.
  struct Stop {};
  const fs::path target = tmp_.path() / "cancelled";
  std::vector<float> seen;
  EXPECT_THROW(build_page_set(surfels_, options_, "k", target,
                              [&](float f) {
                                seen.push_back(f);
                                if (f > 0.56f) throw Stop{};
                              }),
               Stop);
  EXPECT_FALSE(fs::exists(target));

  // A complete build reports monotonic progress ending at 1.
  seen.clear();
  build_page_set(surfels_, options_, "k", tmp_.path() / "done", [&](float f) { seen.push_back(f); });
  ASSERT_FALSE(seen.empty());
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  EXPECT_EQ(seen.back(), 1.f);
  EXPECT_TRUE(leftovers(tmp_.path()).empty());
  // Trailing slash names the same directory.
  build_page_set(surfels_, options_, "k", fs::path(tmp_.path() / "slash") / "");
  EXPECT_TRUE(fs::exists(tmp_.path() / "slash" / kManifestFileName));
  EXPECT_TRUE(leftovers(tmp_.path()).empty());
}

TEST_F(PageSetTest, ConcurrentReadersSeeTheSameTree) {
  const test::Walk want = test::walk(tree::MemoryTree(tree::build_tree(surfels_, options_)));
  // A cache far smaller than the tree: threads keep evicting each other.
  auto cache = std::make_shared<PageCache>(64 * 1024);
  PageSetReader reader(dir_, cache);
  std::vector<test::Walk> got(4);
  std::vector<std::thread> threads;
  for (int i = 0; i < 4; ++i) threads.emplace_back([&, i] { got[i] = test::walk(reader); });
  for (auto& t : threads) t.join();
  for (const auto& w : got) test::expect_same_walk(w, want);
  const CacheCounters c = cache->counters();
  EXPECT_LE(c.bytes_held, cache->budget());
  EXPECT_GT(c.evictions, 0u);
}

// A consumer's attachment (here a fixed-size blob) is built once per load,
// and what the cache holds and charges is the attachment alone.
struct Blob final : tree::PageAttachment {
  explicit Blob(size_t n) : bytes(n) {}
  size_t memory_bytes() const override { return sizeof(Blob) + bytes.capacity(); }
  std::vector<uint8_t> bytes;
};

TEST_F(PageSetTest, DecoratorAttachmentsAreBuiltOncePerLoadAndCharged) {
  std::atomic<int> calls{0};
  constexpr size_t kBlob = 100000;
  auto cache = std::make_shared<PageCache>(uint64_t(1) << 30);
  PageSetReader reader(dir_, cache, [&](tree::Page& p) {
    ++calls;
    p.attachment = std::make_shared<Blob>(kBlob);
  });
  const std::shared_ptr<const tree::PageAttachment> a = reader.attachment(0);
  const std::shared_ptr<const tree::PageAttachment> b = reader.attachment(0);
  EXPECT_EQ(calls.load(), 1);
  ASSERT_NE(a, nullptr);
  EXPECT_EQ(a.get(), b.get());
  EXPECT_EQ(cache->counters().bytes_held, a->memory_bytes() + PageCache::entry_bytes())
      << "the attachment alone is charged";
  // page() hands out the cached attachment under the page's id.
  const tree::PagePtr page = reader.page(0);
  EXPECT_EQ(calls.load(), 1);
  EXPECT_EQ(page->id, 0u);
  EXPECT_EQ(page->attachment.get(), a.get());
  // Read everything: the cache holds every page's blob.
  for (uint32_t i = 0; i < manifest_.stats.page_count; ++i) reader.attachment(i);
  EXPECT_EQ(calls.load(), int(manifest_.stats.page_count));
  EXPECT_GE(cache->counters().bytes_held, uint64_t(kBlob) * manifest_.stats.page_count);

  // A budget of two blobs: the attachments count, so pages are evicted.
  auto small = std::make_shared<PageCache>(2 * kBlob + 50000);
  PageSetReader tight(dir_, small, [&](tree::Page& p) { p.attachment = std::make_shared<Blob>(kBlob); });
  for (uint32_t i = 0; i < manifest_.stats.page_count; ++i) tight.attachment(i);
  EXPECT_LE(small->counters().bytes_held, small->budget());
  EXPECT_GT(small->counters().evictions, 0u);

  // An undecorated reader keeps pages: it has no attachments.
  const PageSetReader plain(dir_, nullptr);
  EXPECT_EQ(plain.attachment(0), nullptr);
}

// A decorated reader decodes page after page into one scratch page per
// thread: the decorator sees each page whole (nothing left from the page
// before, in any order), and the page the reader returns holds its id and
// attachment only.
TEST_F(PageSetTest, ADecoratedReaderKeepsTheAttachmentAlone) {
  const PageSetReader plain(dir_, nullptr);
  // The surfels and nodes each page had, as the decorator saw them.
  struct Seen final : tree::PageAttachment {
    size_t nodes = 0, surfels = 0, links = 0;
    float first_x = 0.f;
    size_t memory_bytes() const override { return sizeof(Seen); }
  };
  const PageSetReader seeing(dir_, nullptr, [](tree::Page& p) {
    auto seen = std::make_shared<Seen>();
    seen->nodes = p.nodes.size();
    seen->surfels = p.surfels.size();
    seen->links = p.links.size();
    seen->first_x = p.surfels.empty() ? 0.f : p.surfels[0].position.x;
    p.attachment = seen;
    if (p.surfels.size() > 1) p.surfels.pop_back();  // what the next page must not see
  });
  const uint32_t pages = manifest_.stats.page_count;
  for (uint32_t k = 0; k < 2 * pages; ++k) {
    const uint32_t id = (k * 7919u) % pages;  // large and small pages in turn
    const tree::PagePtr want = plain.page(id);
    const tree::PagePtr got = seeing.page(id);
    ASSERT_EQ(got->id, id);
    EXPECT_EQ(got->nodes.capacity() + got->surfels.capacity() + got->links.capacity(), 0u) << "page " << id;
    const auto* seen = dynamic_cast<const Seen*>(got->attachment.get());
    ASSERT_NE(seen, nullptr);
    EXPECT_EQ(seen->nodes, want->nodes.size()) << "page " << id;
    EXPECT_EQ(seen->surfels, want->surfels.size()) << "page " << id;
    EXPECT_EQ(seen->links, want->links.size()) << "page " << id;
    EXPECT_EQ(seen->first_x, want->surfels.empty() ? 0.f : want->surfels[0].position.x) << "page " << id;
  }
}

TEST_F(PageSetTest, AThrowingDecoratorFailsTheLoadAndCachesNothing) {
  auto cache = std::make_shared<PageCache>(uint64_t(1) << 30);
  bool fail = true;
  PageSetReader reader(dir_, cache, [&](tree::Page&) {
    if (fail) throw CorruptionError("decorator refused page");
  });
  EXPECT_THROW(reader.page(0), CorruptionError);
  EXPECT_EQ(cache->counters().bytes_held, 0u);
  fail = false;
  // One that attaches nothing fails the load too, naming the page.
  try {
    reader.attachment(0);
    ADD_FAILURE() << "no attachment, no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("page 0"), std::string::npos) << e.what();
  }
  EXPECT_EQ(cache->counters().bytes_held, 0u);
}

TEST(PageSet, DefaultPagesOnLargerInput) {
  test::TempDir tmp;
  const auto surfels = test::random_surfels(20000, 5);
  const Manifest m = build_page_set(surfels, {}, "k", tmp.path() / "s");
  PageSetReader reader(tmp.path() / "s", std::make_shared<PageCache>(uint64_t(1) << 30));
  const test::Walk got = test::walk(reader);
  test::expect_same_walk(got, test::walk(tree::MemoryTree(tree::build_tree(surfels, {}))));
  // Pages follow each other without gaps (V4 pages are not aligned).
  uint64_t page_bytes = 0;
  for (const auto& e : m.pages) {
    EXPECT_LE(e.bytes, 65536u);
    EXPECT_EQ(e.offset, page_bytes);
    page_bytes += e.bytes;
  }
  EXPECT_EQ(page_bytes, m.stats.file_bytes);
}

// The page table is the one part of a build that grows with its pages: the
// build reports its bytes before each growth (set_memory_hook), so that a
// daemon charges them to its budget. Before, a billion surfels' table
// (0.16 GB) grew uncharged beside it.
TEST(PageSet, BuildReportsItsPageTableBeforeEachGrowth) {
  test::TempDir tmp;
  const auto surfels = test::random_surfels(100000, 8);  // ~7,000 pages: the table grows twice
  PageSetBuilder b({}, "k", tmp.path() / "s", tree::surfel_bounds(surfels));
  std::vector<uint64_t> reported;
  b.set_memory_hook([&](uint64_t bytes) { reported.push_back(bytes); });
  b.add(surfels);
  const Manifest m = b.finish();
  ASSERT_GT(m.stats.page_count, 4096u);
  // Each growth twice (both arrays, then the new ones), and the shrink at
  // the end twice.
  ASSERT_GE(reported.size(), 6u);
  EXPECT_EQ(reported.back(), m.pages.memory_bytes());
  // What the table held for its pages never passed what was reported.
  const uint64_t most = *std::max_element(reported.begin(), reported.end());
  EXPECT_GE(most, PageTable::bytes_for(m.stats.page_count));
  EXPECT_LT(most, 4 * PageTable::bytes_for(m.stats.page_count) + 16384);
}

// A hook that refuses the growth (a budget that cannot give it) stops the
// build: the error is the hook's, and nothing is published or left behind.
TEST(PageSet, RefusedPageTableStopsTheBuildLeavingNothing) {
  test::TempDir tmp;
  const auto surfels = test::random_surfels(100000, 9);
  {
    PageSetBuilder b({}, "k", tmp.path() / "s", tree::surfel_bounds(surfels));
    b.set_memory_hook([&](uint64_t bytes) {
      if (bytes > PageTable::bytes_for(4096)) {
        throw ResourceExhausted("page table of " + std::to_string(bytes) + " bytes");
      }
    });
    b.add(surfels);
    try {
      b.finish();
      FAIL() << "the build went on past its refused page table";
    } catch (const ResourceExhausted& e) {
      EXPECT_TRUE(contains(e.what(), "page table of")) << e.what();
    }
  }  // a failed builder removes its staging directory when it goes
  EXPECT_FALSE(fs::exists(tmp.path() / "s"));
  EXPECT_TRUE(fs::is_empty(tmp.path()));
}

// Leaf format A (half floats, float32 positions): the page set reads back
// as the tree built with the same options, every position bit-exact, and
// its manifest (V4) and page flags must agree.
TEST(PageSet, HalfLeafFormatRoundTrip) {
  test::TempDir tmp;
  const std::vector<Surfel> surfels = test::random_surfels(3000, 12);
  tree::BuildOptions o;
  o.page_size = 4096;
  o.leaf_format = LeafFormat::kHalf;
  const Manifest m = build_page_set(surfels, o, "k", tmp.path() / "half");
  tree::BuildOptions relative = o;
  relative.leaf_format = LeafFormat::kRelative;
  const Manifest mr = build_page_set(surfels, relative, "k", tmp.path() / "relative");
  // 38 against 24 bytes per surfel.
  EXPECT_GT(m.stats.file_bytes, mr.stats.file_bytes + 3000 * 10);

  // V8 page sets have V5 manifests, which state the leaf format either way.
  const auto manifest_bytes = read_file(tmp.path() / "half" / kManifestFileName);
  EXPECT_EQ(unframe_manifest(manifest_bytes, "m").version, kManifestFormatV5);
  EXPECT_EQ(unframe_manifest(read_file(tmp.path() / "relative" / kManifestFileName), "m").version, kManifestFormatV5);

  PageSetReader reader(tmp.path() / "half", nullptr);
  EXPECT_EQ(reader.manifest().options.leaf_format, LeafFormat::kHalf);
  const test::Walk got = test::walk(reader);
  test::expect_same_walk(got, test::walk(tree::MemoryTree(tree::build_tree(surfels, o))));
  auto positions = [](const std::vector<Surfel>& v) {
    std::vector<std::array<float, 3>> p;
    for (const Surfel& s : v) p.push_back({s.position.x, s.position.y, s.position.z});
    std::sort(p.begin(), p.end());
    return p;
  };
  EXPECT_EQ(positions(got.surfels), positions(surfels));

  // A manifest that says "relative" over half pages: every page refused.
  Manifest lie = decode_manifest(manifest_bytes, "m");
  lie.options.leaf_format = LeafFormat::kRelative;
  write_file(tmp.path() / "half" / kManifestFileName, encode_manifest(lie));
  PageSetReader liar(tmp.path() / "half", nullptr);
  try {
    (void)liar.page(0);
    FAIL() << "a half page decoded as relative";
  } catch (const CorruptionError& e) {
    EXPECT_TRUE(contains(e.what(), "flags")) << e.what();
  }
  // And a manifest naming an unknown leaf format is corrupt.
  auto body = unframe_manifest(manifest_bytes, "m").body;
  std::vector<uint8_t> raw(body.begin(), body.end());
  raw[raw.size() - 4] = 7;  // the leaf_format u32, last in the body
  write_file(tmp.path() / "half" / kManifestFileName, frame_manifest(raw, kManifestFormatV5));
  EXPECT_THROW(PageSetReader(tmp.path() / "half", nullptr), CorruptionError);
}

TEST(PageSet, RejectsBadArguments) {
  test::TempDir tmp;
  tree::BuildOptions bad;
  bad.leaf_size = 0;
  EXPECT_THROW(build_page_set(test::random_surfels(10), bad, "k", tmp.path() / "a"), InvalidArgument);
  EXPECT_THROW(build_page_set({}, {}, "k", tmp.path() / "b"), InvalidArgument);
  EXPECT_THROW(build_page_set(test::random_surfels(10), {}, std::string(5000, 'k'), tmp.path() / "c"), InvalidArgument);
  EXPECT_TRUE(fs::is_empty(tmp.path()));
}

}  // namespace
}  // namespace pbgi::storage
