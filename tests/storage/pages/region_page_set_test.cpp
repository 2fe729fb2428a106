// Air regions in the page set (storage/tree/region_grid.h): each region's
// surfels form a subtree of their own, listed with the grid in a V6
// manifest; a stream of one region builds the tree it always did.
#include "common/errors.h"
#include "storage/cache/page_cache.h"
#include "storage/pages/manifest_file.h"
#include "storage/pages/page_set.h"
#include "storage/tree/morton.h"
#include "storage/tree/tree_builder.h"
#include "tests/storage/pages/temp_dir.h"
#include "tests/storage/pages/tree_walk.h"
#include "tests/storage/tree/random_surfels.h"

#include <gtest/gtest.h>

#include <functional>

namespace pbgi::storage {
namespace {

tree::RegionGrid two_region_grid() {
  // 2 x 1 x 1 voxels: region 1 and region 2 side by side.
  return tree::RegionGrid::from_dense({-10, -10, -10}, 10.f, {2, 1, 1}, {1, 2});
}

// Surfels of a thin wall's two faces, 1 cm apart and interleaved in Morton
// order: the lit face (z = 0, region 1) and the dark one (z = 0.01, region 2).
std::vector<Surfel> wall_surfels(size_t n) {
  std::vector<Surfel> out = test::random_surfels(n, 5);
  for (size_t i = 0; i < n; ++i) {
    Surfel& s = out[i];
    s.position.z = i % 2 ? 0.01f : 0.f;
    s.normal = {0, 0, i % 2 ? 1.f : -1.f};
    s.region = i % 2 ? 2 : 1;
  }
  return out;
}

// The surfels below `root`, walked through `src`.
std::vector<Surfel> surfels_below(const tree::TreeSource& src, const tree::NodeRef& root) {
  struct Rooted : tree::TreeSource {
    const tree::TreeSource& src;
    tree::NodeRef r;
    Rooted(const tree::TreeSource& s, tree::NodeRef x) : src(s), r(x) {}
    tree::NodeRef root() const override { return r; }
    tree::PagePtr page(uint32_t id) const override { return src.page(id); }
  } rooted(src, root);
  return test::walk(rooted).surfels;
}

// The page set of `surfels` in `dir` with two_region_grid(), 4 KiB pages.
Manifest build_with_regions(const std::vector<Surfel>& surfels, const std::filesystem::path& dir) {
  tree::BuildOptions o;
  o.page_size = 4096;
  PageSetBuilder b(o, "regions", dir, tree::surfel_bounds(surfels));
  b.add(surfels);
  b.set_regions(two_region_grid());
  return b.finish();
}

TEST(RegionPageSet, EachRegionIsASubtreeOfItsOwn) {
  test::TempDir tmp;
  const std::vector<Surfel> surfels = wall_surfels(20000);
  const Manifest m = build_with_regions(surfels, tmp.path() / "set");
  ASSERT_EQ(m.region_roots.size(), 2u);
  EXPECT_EQ(m.region_roots[0].region, 1u);
  EXPECT_EQ(m.region_roots[1].region, 2u);

  PageSetReader reader(tmp.path() / "set", std::make_shared<PageCache>(uint64_t(64) << 20));
  ASSERT_NE(reader.regions(), nullptr);
  EXPECT_EQ(*reader.regions(), two_region_grid());
  ASSERT_EQ(reader.region_roots().size(), 2u);
  // Every surfel under region 1's root is on the lit face, under region
  // 2's on the dark face, and the whole tree holds both.
  for (const tree::RegionRoot& r : reader.region_roots()) {
    EXPECT_EQ(r.root.index, 0u);  // a page's root
    const std::vector<Surfel> below = surfels_below(reader, r.root);
    EXPECT_EQ(below.size(), surfels.size() / 2) << "region " << r.region;
    for (const Surfel& s : below) ASSERT_EQ(s.normal.z > 0.f, r.region == 2) << "region " << r.region;
  }
  EXPECT_EQ(test::walk(reader).surfels.size(), surfels.size());
}

TEST(RegionPageSet, OneRegionBuildsTheTreeAsBefore) {
  test::TempDir tmp;
  std::vector<Surfel> surfels = test::random_surfels(8000, 9);
  tree::BuildOptions o;
  o.page_size = 4096;
  auto build = [&](const char* name) {
    PageSetBuilder b(o, "one", tmp.path() / name, tree::surfel_bounds(surfels));
    b.add(surfels);
    return b.finish();
  };
  const Manifest plain = build("plain");
  for (Surfel& s : surfels) s.region = 7;
  const Manifest seven = build("seven");
  EXPECT_TRUE(seven.region_roots.empty());
  EXPECT_EQ(seven.stats.page_count, plain.stats.page_count);
  EXPECT_EQ(seven.stats.file_bytes, plain.stats.file_bytes);
  EXPECT_EQ(manifest_format_of(seven), kManifestFormatV5);
}

TEST(RegionPageSet, SurfelsOfSeveralRegionsNeedTheGrid) {
  test::TempDir tmp;
  const std::vector<Surfel> surfels = wall_surfels(2000);
  PageSetBuilder b(tree::BuildOptions{}, "no-grid", tmp.path() / "set", tree::surfel_bounds(surfels));
  b.add(surfels);
  EXPECT_THROW(b.finish(), InvalidArgument);
  EXPECT_FALSE(std::filesystem::exists(tmp.path() / "set"));
}

TEST(RegionPageSet, DamagedRegionSectionsAreRefused) {
  test::TempDir tmp;
  const Manifest m = build_with_regions(wall_surfels(4000), tmp.path() / "set");
  EXPECT_EQ(manifest_format_of(m), kManifestFormatV6);
  const Manifest back = decode_manifest(encode_manifest(m), "manifest");
  EXPECT_EQ(back.regions, m.regions);
  EXPECT_EQ(back.region_roots, m.region_roots);
  // A root outside the pages, roots out of order: refused with the file named.
  Manifest bad = m;
  bad.region_roots[1].root.page = m.stats.page_count;
  EXPECT_THROW(decode_manifest(encode_manifest(bad), "manifest"), CorruptionError);
  bad = m;
  std::swap(bad.region_roots[0], bad.region_roots[1]);
  EXPECT_THROW(decode_manifest(encode_manifest(bad), "manifest"), CorruptionError);
}

}  // namespace
}  // namespace pbgi::storage
