// The gather over a real on-disk page set (storage/pages), built by the
// production tree builder and read through the page cache.
#include "server/gather/gather.h"
#include "server/gather/page_views.h"
#include "storage/cache/page_cache.h"
#include "storage/pages/page_set.h"
#include "surfel_shapes.h"
#include "surfel_tree.h"
#include "tests/storage/bench/synthetic_city.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

namespace pbgi {
namespace {

using Imath::C3f;
using Imath::V3d;
using Imath::V3f;
namespace fs = std::filesystem;
constexpr float kPi = 3.14159265358979f;

class TempDir {
 public:
  TempDir() {
    std::random_device rd;
    path_ = fs::temp_directory_path() / ("pbgi_gather_test_" + std::to_string(rd()));
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

// Emitter disk (radius 1, height 2, radiance 1) and a black disk occluder
// (radius 0.6, height 0.5) centered at x = `occluder_x`.
std::vector<Surfel> scene(float occluder_x) {
  std::vector<Surfel> s;
  test::add_disk(s, {0, 0, 2}, {0, 0, -1}, 1.f, 8000, C3f(1));
  test::add_disk(s, {occluder_x, 0, 0.5f}, {0, 0, -1}, 0.6f, 3000, C3f(0));
  return s;
}

std::unique_ptr<storage::PageSetReader> build(const std::vector<Surfel>& surfels, const fs::path& dir,
                                              uint64_t cache_bytes, storage::PageDecorator decorate = {}) {
  tree::BuildOptions o;
  o.page_size = 16384;  // several pages even for this small scene
  storage::build_page_set(surfels, o, "gather-test", dir);
  return std::make_unique<storage::PageSetReader>(dir, std::make_shared<storage::PageCache>(cache_bytes),
                                                  std::move(decorate));
}

TEST(GatherPageSet, MatchesClosedFormAndTheInMemoryTree) {
  TempDir tmp;
  const std::vector<Surfel> surfels = scene(3.f);  // occluder aside
  auto reader = build(surfels, tmp.path() / "set", 64 << 20);
  ASSERT_GT(reader->manifest().stats.page_count, 1u);
  test::SurfelTree memory(surfels);
  Gatherer on_disk(*reader, GatherOptions{}), in_memory(memory, GatherOptions{});
  for (const float deg : {0.f, 30.f, 60.f}) {
    const float tau = deg * kPi / 180.f;
    const Receiver r{V3f(0), V3f(std::sin(tau), 0, std::cos(tau))};
    const GatherResult a = on_disk.gather(r);
    const GatherResult b = in_memory.gather(r);
    const float expect = kPi / 5.f * std::cos(tau);
    std::printf("tau %2.0f: page set E = %.5f, memory tree E = %.5f, closed form %.5f\n", deg, a.irradiance.x,
                b.irradiance.x, expect);
    EXPECT_NEAR(a.irradiance.x, expect, 0.03f * expect);
    EXPECT_NEAR(a.irradiance.x, b.irradiance.x, 0.02f * expect);
    EXPECT_NEAR(a.ao, b.ao, 0.01f);
  }
  EXPECT_GT(on_disk.counters().pages_fetched, 3u);
}

TEST(GatherPageSet, OccluderHidesEmitterEvenWithAnEvictingCache) {
  // A 1-byte cache keeps nothing: pages live only as long as the gather
  // pins them.
  TempDir tmp;
  auto reader = build(scene(0.f), tmp.path() / "set", 1);
  Gatherer g(*reader, GatherOptions{});
  for (int i = 0; i < 3; ++i) {
    const GatherResult r = g.gather({V3f(0.05f * float(i), 0, 0), V3f(0, 0, 1)});
    EXPECT_LT(r.irradiance.x, 0.01f * kPi / 5.f);
    EXPECT_NEAR(r.ao, 1.f - 0.36f / 0.61f, 0.02f);
  }
}

// Views attached to cached pages (as the daemon installs them) give the
// same results as views each Gatherer builds, with a roomy cache and with
// one that evicts every page after use.
TEST(GatherPageSet, AttachedViewsGiveIdenticalResults) {
  TempDir tmp;
  const std::vector<Surfel> surfels = scene(0.4f);
  auto plain = build(surfels, tmp.path() / "a", 64 << 20);
  auto attached = build(surfels, tmp.path() / "b", 64 << 20, gather::attach_view);
  auto evicting = build(surfels, tmp.path() / "c", 1, gather::attach_view);
  Gatherer a(*plain, GatherOptions{}), b(*attached, GatherOptions{}), c(*evicting, GatherOptions{});
  for (int i = 0; i < 8; ++i) {
    const Receiver r{V3f(0.1f * float(i) - 0.4f, 0.05f * float(i), 0), V3f(0.1f * float(i), 0, 1).normalized()};
    const GatherResult ra = a.gather(r), rb = b.gather(r), rc = c.gather(r);
    EXPECT_EQ(ra.irradiance, rb.irradiance);
    EXPECT_EQ(ra.irradiance, rc.irradiance);
    EXPECT_EQ(ra.ao, rb.ao);
    EXPECT_EQ(ra.ao, rc.ao);
  }
  const tree::PagePtr root_page = attached->page(attached->root().page);
  ASSERT_NE(root_page->attachment, nullptr);
  EXPECT_GT(root_page->attachment->memory_bytes(), 0u);
}

// A page's view is one allocation laid out for entering the page: its
// header line is 128-byte aligned and node 0 (the page's root, where a
// walk enters) is the next line, in the same pair, so a walk entering a
// page waits for one pair instead of the header and then the node
// (page_views.h); the proxies follow the page's nodes.
TEST(GatherPageSet, ViewIsOneAllocationWithTheRootBesideItsHeader) {
  TempDir tmp;
  tree::BuildOptions o;
  o.page_size = 4096;
  storage::build_page_set(scene(0.4f), o, "gather-test", tmp.path() / "set");
  const storage::PageSetReader reader(tmp.path() / "set", nullptr);
  size_t proxies = 0;
  for (uint32_t id = 0; id < reader.manifest().stats.page_count; ++id) {
    const tree::PagePtr page = reader.page(id);
    const gather::PageView::Ptr view = gather::PageView::build(*page);
    const auto at = reinterpret_cast<uintptr_t>(view.get());
    ASSERT_EQ(at % 128, 0u) << "page " << id;
    ASSERT_EQ(reinterpret_cast<uintptr_t>(view->packed_nodes()), at + 64) << "page " << id;
    ASSERT_EQ(view->node_count, page->nodes.size() + page->links.size());
    EXPECT_TRUE(view->matches(*page));
    EXPECT_GE(view->memory_bytes(), 64 + view->node_count * (sizeof(gather::PackedNode) + sizeof(gather::PackedLook)));
    for (uint32_t i = 0; i < view->node_count; ++i) {
      const gather::HotNode h = view->node(i);
      const tree::Node& n = i < page->nodes.size() ? page->nodes[i] : page->links[i - page->nodes.size()].summary;
      EXPECT_EQ(h.cx, n.center.x) << "page " << id << " node " << i;
      EXPECT_EQ(h.radius, n.radius) << "page " << id << " node " << i;
      // The axis code moves the axis by at most 2.6e-5; the cone is the
      // node's.
      if (n.cone_cos > -1.f) {
        EXPECT_LE((V3d(h.ax, h.ay, h.az) - V3d(n.cone_axis)).length(), 2.7e-5) << "page " << id << " node " << i;
        EXPECT_EQ(h.cone_cos, std::min(n.cone_cos, 1.f)) << "page " << id << " node " << i;
      }
      EXPECT_EQ(h.proxy(), i >= page->nodes.size()) << "page " << id << " node " << i;
      proxies += h.proxy();
    }
  }
  EXPECT_GT(proxies, 0u) << "the set has linked children";
}

// A page describes each child in another page exactly (tree::Page::links),
// so the walk decides on such a child from its proxy and loads the child's
// page only to open it: the same results and node visits as a walk that
// loads every linked page it meets, from fewer pages.
TEST(GatherPageSet, ProxiesOfLinkedChildrenChangeOnlyThePagesLoaded) {
  TempDir tmp;
  const std::vector<Surfel> surfels = scene(0.4f);
  tree::BuildOptions o;
  o.page_size = 4096;
  storage::build_page_set(surfels, o, "gather-test", tmp.path() / "set");
  auto no_proxies = [](tree::Page& p) {
    p.links.clear();
    gather::attach_view(p);
  };
  storage::PageSetReader with(tmp.path() / "set", nullptr, gather::attach_view);
  storage::PageSetReader without(tmp.path() / "set", nullptr, no_proxies);
  {
    const storage::PageSetReader plain(tmp.path() / "set", nullptr);
    ASSERT_FALSE(plain.page(plain.root().page)->links.empty()) << "the root page links to other pages";
  }
  for (const GatherMethod method : {GatherMethod::kPbgi, GatherMethod::kFpbgi}) {
    GatherOptions options;
    options.method = method;
    Gatherer a(with, options), b(without, options);
    std::vector<Receiver> receivers;
    for (int i = 0; i < 16; ++i) {
      // Below the emitter, some far off to the side: cuts stop at every depth.
      receivers.push_back(
          {V3f(0.3f * float(i) - 2.f, 0.1f * float(i % 4), 0), V3f(0.05f * float(i % 3), 0, 1).normalized()});
    }
    std::vector<GatherResult> ra(receivers.size()), rb(receivers.size());
    a.gather_tile(receivers, ra);
    b.gather_tile(receivers, rb);
    for (size_t i = 0; i < receivers.size(); ++i) {
      EXPECT_EQ(ra[i].irradiance, rb[i].irradiance) << "receiver " << i;
      EXPECT_EQ(ra[i].ao, rb[i].ao) << "receiver " << i;
    }
    EXPECT_EQ(a.counters().nodes_visited, b.counters().nodes_visited);
    EXPECT_LT(a.counters().pages_fetched, b.counters().pages_fetched);
    std::printf("method %d: %llu pages fetched with proxies, %llu without\n", int(method),
                (unsigned long long)a.counters().pages_fetched, (unsigned long long)b.counters().pages_fetched);
  }
}

// Every page the build writes holds at most upper_page_levels levels of the
// tree (tests/storage/pages/streaming_build_test.cpp checks which pages may
// take them), and links carry their child's root.
TEST(GatherPageSet, PagesSpanAtMostThePageLevelsAndLinksMatchTheirChildren) {
  TempDir tmp;
  tree::BuildOptions o;
  o.page_size = 65536;  // large enough that the level bound, not the size, cuts pages
  storage::build_page_set(scene(0.4f), o, "gather-test", tmp.path() / "set");
  storage::PageSetReader reader(tmp.path() / "set", nullptr);
  size_t links = 0;
  for (uint32_t id = 0; id < reader.manifest().stats.page_count; ++id) {
    const tree::PagePtr page = reader.page(id);
    // Depth of every node in its page: parents come before children.
    std::vector<uint32_t> depth(page->nodes.size(), 1);
    for (size_t i = 0; i < page->nodes.size(); ++i) {
      EXPECT_LE(depth[i], o.upper_page_levels) << "page " << id << " node " << i;
      const tree::Node& n = page->nodes[i];
      for (uint32_t c = 0; c < n.child_count; ++c) {
        if (n.children[c].page == id) depth[n.children[c].index] = depth[i] + 1;
      }
    }
    for (const tree::PageLink& l : page->links) {
      const tree::PagePtr child_page = reader.page(l.summary.children[0].page);
      const tree::Node& child = child_page->nodes[0];
      EXPECT_EQ(l.summary.center, child.center);
      EXPECT_EQ(l.summary.radius, child.radius);
      EXPECT_EQ(l.summary.cone_cos, child.cone_cos);
      EXPECT_EQ(l.summary.area, child.area);
      for (int k = 0; k < 9; ++k) {
        EXPECT_EQ(l.summary.coverage_sh[k], child.coverage_sh[k]);
        EXPECT_EQ(l.summary.radiance_sh.r[k], child.radiance_sh.r[k]);
      }
      ++links;
    }
  }
  EXPECT_EQ(links + 1, reader.manifest().stats.page_count) << "every page but the root's is linked once";
}

// A page that carries its view keeps nothing else of its content: its
// decoded nodes, links and surfels are freed, not only emptied (an empty
// assignment kept their capacity, and the cache charged and held every
// decoded node beside its view: 7.7x the page's bytes on disk instead of 3.1x).
TEST(GatherPageSet, AttachedViewFreesThePagesDecodedContent) {
  TempDir tmp;
  storage::build_page_set(scene(0.4f), tree::BuildOptions{}, "gather-test", tmp.path() / "set");
  const storage::PageSetReader plain(tmp.path() / "set", nullptr);
  const storage::PageSetReader attached(tmp.path() / "set", nullptr, gather::attach_view);
  for (uint32_t id = 0; id < plain.manifest().stats.page_count; ++id) {
    const tree::PagePtr full = plain.page(id), page = attached.page(id);
    ASSERT_GT(full->nodes.size(), 0u);
    EXPECT_EQ(page->nodes.capacity(), 0u) << "page " << id;
    EXPECT_EQ(page->links.capacity(), 0u) << "page " << id;
    EXPECT_EQ(page->surfels.capacity(), 0u) << "page " << id;
    ASSERT_NE(page->attachment, nullptr);
    EXPECT_EQ(page->memory_bytes(), tree::heap_block_bytes(tree::Page::kSharedControlBytes + sizeof(tree::Page)) +
                                        page->attachment->memory_bytes())
        << "page " << id;
    // The view's leaf surfels are the page's, in their order, within the
    // precision of their codes (page_views.h: PackedSurfel), relative to
    // the radius R of their leaf's sphere; the radiance, RGB9E5 on disk, to
    // the bit.
    gather::PageViews views;
    const gather::PageView& v = views.get(*page);
    ASSERT_EQ(v.surfel_count, full->surfels.size());
    size_t seen = 0;
    for (uint32_t i = 0; i < v.page_nodes; ++i) {
      const gather::HotNode h = v.node(i);
      if (!h.leaf()) continue;
      const double r = h.radius;
      for (uint32_t k = h.first(); k < h.first() + h.size(); ++k, ++seen) {
        const Surfel& s = full->surfels[k];
        const gather::LeafSurfel l = v.surfel(h, k);
        EXPECT_LE((V3d(l.position) - V3d(s.position)).length(), r * 0.87 / 32767 + 1e-6 * r)
            << "page " << id << " surfel " << k;
        EXPECT_LE(std::abs(double(l.radius) - s.radius), r * 0.51 / 65535 + 1e-6 * r)
            << "page " << id << " surfel " << k;
        EXPECT_LE((V3d(l.normal) - V3d(s.normal)).length(), 2.7e-5) << "page " << id << " surfel " << k;
        EXPECT_EQ(l.radiance, s.radiance) << "page " << id << " surfel " << k;
      }
    }
    EXPECT_EQ(seen, full->surfels.size()) << "page " << id;
  }
}

// What a cached page costs against its bytes on disk, on a page set shaped
// like the daemon's (a generated city at default build options: cut-shaped
// pages of ~9 nodes and ~13 surfels). The page cache's budget is set in
// bytes on disk (1/8 of the page set), so this ratio is how much of a
// budget's worth of pages the cache can hold. Issue 19 asks for 2x; the
// view reaches kMaxDecodedOverDisk (docs/out-of-core.md: what is left is
// the cache's entry and the view's control block and header, ~250 bytes,
// and 32-byte nodes, 16-byte looks and 20-byte surfels).
// 7.7x before the view freed the page's decoded nodes; 5.2x with float
// records in the view over V6 pages; 3.1x with packed ones; 5.0x with
// packed ones over V8 pages (the same views, ~35 % fewer bytes on disk:
// docs/measurements/2026-11-27-compact-v8.md); 5.7x over V10 pages (~14 %
// fewer again: docs/measurements/2026-11-28-page-format-v10.md); 5.1x
// once the cache held views alone, without a Page record and an
// attachment block (docs/measurements/2026-11-28-cache-holds-views.md:
// 5.11x, 1,214 bytes a page, with the view's rare parts in its arrays
// and its block charged as the allocator holds it).
TEST(GatherPageSet, CachedPageCostsAFewTimesItsBytesOnDisk) {
  constexpr double kMaxDecodedOverDisk = 5.5;
  constexpr uint64_t kMaxChargePerPage = 1350;
  TempDir tmp;
  const test::SyntheticCity city(60000, 4);
  std::vector<Surfel> surfels;
  city.generate(4096, [&](std::span<const Surfel> b) { surfels.insert(surfels.end(), b.begin(), b.end()); });
  storage::build_page_set(surfels, tree::BuildOptions{}, "gather-test", tmp.path() / "set");
  auto cache = std::make_shared<storage::PageCache>(~uint64_t(0));
  const storage::PageSetReader reader(tmp.path() / "set", cache, gather::attach_view);
  const storage::Manifest& m = reader.manifest();
  ASSERT_GT(m.stats.page_count, 1000u) << "cut-shaped pages";
  uint64_t charged = 0;
  for (uint32_t id = 0; id < m.stats.page_count; ++id) charged += reader.attachment(id)->memory_bytes();
  charged += uint64_t(m.stats.page_count) * storage::PageCache::entry_bytes();  // the cache's bookkeeping
  EXPECT_EQ(cache->counters().bytes_held, charged) << "what the cache holds is what it charges";
  const double ratio = double(charged) / double(m.stats.file_bytes);
  std::printf("%u pages: %.2fx their bytes on disk charged, %llu bytes a page\n", m.stats.page_count, ratio,
              (unsigned long long)(charged / m.stats.page_count));
  EXPECT_LE(ratio, kMaxDecodedOverDisk) << charged << " bytes charged for " << m.stats.file_bytes << " on disk";
  EXPECT_LE(charged / m.stats.page_count, kMaxChargePerPage);
}

// A budget changes speed only: one page set read through caches of no
// room, of about 1/8 of its decoded pages and of everything, by two
// threads gathering at once (so pages are evicted while the other thread
// holds them), gives bit-identical results for every receiver.
TEST(GatherPageSet, ResultsIdenticalWhateverTheBudget) {
  TempDir tmp;
  const std::vector<Surfel> surfels = scene(0.4f);
  tree::BuildOptions o;
  o.page_size = 4096;  // many pages, so that 1/8 of them really evicts
  storage::build_page_set(surfels, o, "gather-test", tmp.path() / "set");
  uint64_t decoded = 0;
  {
    storage::PageSetReader probe(tmp.path() / "set", nullptr, gather::attach_view);
    ASSERT_GT(probe.manifest().stats.page_count, 16u);
    for (uint32_t p = 0; p < probe.manifest().stats.page_count; ++p) decoded += probe.attachment(p)->memory_bytes();
  }
  std::vector<Receiver> receivers;
  receivers.reserve(64);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  for (int i = 0; i < 64; ++i) {
    receivers.push_back(
        {V3f(1.5f * u(rng), 1.5f * u(rng), 0.3f * u(rng)), V3f(0.3f * u(rng), 0.3f * u(rng), 1).normalized()});
  }
  auto run = [&](uint64_t budget, storage::CacheCounters* counters) {
    auto cache = std::make_shared<storage::PageCache>(budget);
    storage::PageSetReader reader(tmp.path() / "set", cache, gather::attach_view);
    std::vector<GatherResult> out(receivers.size());
    std::vector<std::thread> threads;
    std::atomic<int> running{2};
    for (size_t t = 0; t < 2; ++t) {
      threads.emplace_back([&, t] {
        Gatherer g(reader, GatherOptions{});
        for (size_t i = t; i < receivers.size(); i += 2) out[i] = g.gather(receivers[i]);
        --running;
      });
    }
    // The budget holds all along, not only once the gathers are done.
    uint64_t most_held = 0;
    while (running > 0) {
      most_held = std::max(most_held, cache->counters().bytes_held);
      std::this_thread::yield();
    }
    for (auto& t : threads) t.join();
    EXPECT_LE(most_held, budget);
    *counters = cache->counters();
    return out;
  };
  storage::CacheCounters none{}, eighth{}, all{};
  const auto a = run(1, &none);
  const auto b = run(decoded / 8, &eighth);
  const auto c = run(~uint64_t(0), &all);
  EXPECT_GT(eighth.evictions, 0u) << "1/8 of the pages must not hold the working set";
  EXPECT_LE(eighth.bytes_held, decoded / 8);
  EXPECT_EQ(all.evictions, 0u);
  EXPECT_GT(none.misses, eighth.misses);
  EXPECT_GT(eighth.misses, all.misses);
  for (size_t i = 0; i < receivers.size(); ++i) {
    EXPECT_EQ(a[i].irradiance, c[i].irradiance) << "receiver " << i;
    EXPECT_EQ(b[i].irradiance, c[i].irradiance) << "receiver " << i;
    EXPECT_EQ(a[i].ao, c[i].ao) << "receiver " << i;
    EXPECT_EQ(b[i].ao, c[i].ao) << "receiver " << i;
  }
}

}  // namespace
}  // namespace pbgi
