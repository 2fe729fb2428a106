// No allocation per receiver: once a Gatherer has gathered a few receivers
// (its scratch has grown to its working size), gathering more of them over
// a page set read through a warm page cache allocates nothing: not in the
// walk, the rasterizer, the microbuffer, nor in the page cache's hits.
// This binary counts every allocation through a replaced operator new.
#include "server/gather/gather.h"
#include "server/gather/page_views.h"
#include "storage/cache/page_cache.h"
#include "storage/pages/page_set.h"
#include "surfel_shapes.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <new>
#include <random>
#include <string>
#include <vector>

namespace {
std::atomic<uint64_t> g_allocations{0};
}  // namespace

void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) { return operator new(size); }
void* operator new(std::size_t size, std::align_val_t align) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  const std::size_t a = static_cast<std::size_t>(align);
  if (void* p = std::aligned_alloc(a, (size + a - 1) / a * a)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size, std::align_val_t align) { return operator new(size, align); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace pbgi {
namespace {

using Imath::V3f;
namespace fs = std::filesystem;

TEST(GatherAllocation, NoAllocationPerReceiverOnAWarmPageSet) {
  const fs::path dir =
      fs::temp_directory_path() / ("pbgi_gather_alloc_" + std::to_string(std::random_device{}()));
  fs::create_directories(dir);
  tree::BuildOptions o;
  o.page_size = 16384;  // many pages: every receiver fetches dozens
  storage::build_page_set(test::box_room(4.f, 20000), o, "alloc-test", dir / "set");
  {
    storage::PageSetReader reader(dir / "set", std::make_shared<storage::PageCache>(256 << 20),
                                  gather::attach_view);
    ASSERT_GT(reader.manifest().stats.page_count, 8u);
    std::vector<Receiver> receivers;
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-1.8f, 1.8f);
    for (int i = 0; i < 64; ++i) receivers.push_back({V3f(u(rng), u(rng), 0.001f), V3f(0, 0, 1)});
    Gatherer g(reader, GatherOptions{});
    // Warm up: the cache loads its pages, the scratch grows.
    for (const Receiver& r : receivers) g.gather(r);
    for (const Receiver& r : receivers) g.gather(r);
    const uint64_t fetched = g.counters().pages_fetched;
    const uint64_t before = g_allocations.load();
    float sum = 0.f;
    for (const Receiver& r : receivers) sum += g.gather(r).irradiance.x;
    const uint64_t allocations = g_allocations.load() - before;
    EXPECT_GT(sum, 0.f);
    EXPECT_GT(g.counters().pages_fetched - fetched, 8 * receivers.size())
        << "each receiver must fetch its pages from the cache";
    EXPECT_EQ(allocations, 0u) << "over " << receivers.size() << " receivers";
  }
  std::error_code ec;
  fs::remove_all(dir, ec);
}

}  // namespace
}  // namespace pbgi
