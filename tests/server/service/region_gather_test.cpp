// The Gather RPC's receivers and air regions (docs/gather.md, section 15):
// given the scene's rays, a receiver inside a closed box walks only the
// inside's subtree and sees none of the light of the box's lit outside;
// without rays (or regions) it walks the whole tree, as before.
#include "server/scene/air_regions.h"
#include "server/service/interpolated_gather.h"
#include "server/service/parallel_gather.h"
#include "storage/cache/page_cache.h"
#include "storage/pages/page_set.h"
#include "storage/tree/tree_builder.h"
#include "tests/server/scene/test_scenes.h"
#include "tests/server/service/temp_dir.h"

#include <gtest/gtest.h>

namespace pbgi::service {
namespace {

// Surfels on a grid over the quad corner + [0,1] u + [0,1] v, facing n.
void add_surfels(std::vector<Surfel>& out, const V3f& corner, const V3f& u, const V3f& v, const V3f& n,
                 const C3f& radiance, int per_side) {
  const float r = 0.6f * std::max(u.length(), v.length()) / float(per_side);
  for (int j = 0; j < per_side; ++j) {
    for (int i = 0; i < per_side; ++i) {
      Surfel s;
      s.position = corner + u * ((float(i) + 0.5f) / float(per_side)) + v * ((float(j) + 0.5f) / float(per_side));
      s.normal = n;
      s.radius = r;
      s.albedo = C3f(0.5f);
      s.radiance = radiance;
      out.push_back(s);
    }
  }
}

// Gives each surfel its region in `scene`'s grid and builds their page set
// in `dir` (8 KiB pages); `subtrees` gets the number of region subtrees.
std::unique_ptr<storage::PageSetReader> open_with_regions(const Scene& scene, const RayScene& rays, uint32_t resolution,
                                                          std::vector<Surfel>& surfels,
                                                          const std::filesystem::path& dir, size_t& subtrees) {
  const tree::RegionGrid grid = build_air_regions(scene, rays, resolution);
  for (Surfel& s : surfels) s.region = locate_region(grid, rays, s.position, s.normal, true);
  tree::BuildOptions o;
  o.page_size = 8192;
  storage::PageSetBuilder b(o, "regions", dir, tree::surfel_bounds(surfels));
  b.add(surfels);
  b.set_regions(grid);
  subtrees = b.finish().region_roots.size();
  return std::make_unique<storage::PageSetReader>(dir, std::make_shared<storage::PageCache>(uint64_t(64) << 20));
}

// n receivers facing up along x from x0 to x1 at height y, depth z.
std::vector<Receiver> floor_row(int n, float x0, float x1, float y, float z) {
  std::vector<Receiver> row;
  row.reserve(size_t(n));
  for (int i = 0; i < n; ++i) row.push_back({{x0 + (x1 - x0) * (float(i) + 0.5f) / float(n), y, z}, {0, 1, 0}});
  return row;
}

TEST(RegionGather, AReceiverInsideAClosedBoxSeesNothingOfItsLitOutside) {
  // A 2 m box of two shells 2 cm apart: inner faces dark, outer faces lit.
  Scene scene;
  scene.source_path = "box";
  const uint32_t m = test::add_material(scene, {0.5f, 0.5f, 0.5f});
  std::vector<Surfel> surfels;
  for (const float half : {1.f, 1.02f}) {
    const bool outer = half > 1.f;
    const C3f radiance = outer ? C3f(1.f) : C3f(0.f);
    for (int axis = 0; axis < 3; ++axis) {
      for (const float sign : {-1.f, 1.f}) {
        V3f n(0.f), u(0.f), v(0.f);
        n[axis] = sign;
        u[(axis + 1) % 3] = 2 * half;
        v[(axis + 2) % 3] = 2 * half;
        const V3f corner = n * half - (u + v) * 0.5f;
        const V3f facing = outer ? n : -n;
        // The quad's winding faces `facing`.
        if ((u.cross(v)).dot(facing) > 0) test::add_quad(scene, corner, corner + u, corner + u + v, corner + v, m);
        else test::add_quad(scene, corner, corner + v, corner + u + v, corner + u, m);
        add_surfels(surfels, corner, u, v, facing, radiance, 24);
      }
    }
  }
  const RayScene rays(scene);
  testing::TempDir tmp;
  size_t subtrees = 0;
  const auto tree = open_with_regions(scene, rays, 32, surfels, tmp.path() / "set", subtrees);
  ASSERT_EQ(subtrees, 2u);
  // Receivers on the inner floor, facing up.
  const std::vector<Receiver> inside = floor_row(16, -0.85f, 0.75f, -1.f, 0.3f);
  GatherOptions options;
  const GatherBatch with = gather_receivers(*tree, inside, options, {}, nullptr, &rays);
  const GatherBatch without = gather_receivers(*tree, inside, options, {}, nullptr, nullptr);
  const GatherBatch interpolated = gather_interpolated(*tree, inside, options, 0.1f, {}, nullptr, &rays);
  for (size_t i = 0; i < inside.size(); ++i) {
    EXPECT_EQ(with.results[i].irradiance, C3f(0.f)) << i;
    EXPECT_EQ(interpolated.results[i].irradiance, C3f(0.f)) << i;
  }
  // The inside's walls still occlude: the receivers see a closed room
  // (accessibility 0).
  for (const GatherResult& r : with.results) EXPECT_LT(r.ao, 0.05f);
  // Without rays the whole tree is walked: the outside's nodes too.
  EXPECT_LT(with.counters.nodes_visited, without.counters.nodes_visited);
}

// A closed block standing inside a lit room: receivers on the floor under
// it see nothing (their records would be valid everywhere in the floor's
// plane); interpolation must not carry them to the lit floor around it.
TEST(RegionGather, InterpolationDoesNotCrossRegions) {
  Scene scene;
  scene.source_path = "room-and-block";
  const uint32_t m = test::add_material(scene, {0.5f, 0.5f, 0.5f});
  std::vector<Surfel> surfels;
  // The room [-1, 1]^3, faces inward, lit walls; the block [-0.3, 0.3] x
  // [-1, -0.6] x [-0.3, 0.3], faces outward, dark (no surfel faces into it:
  // only the floor under it does).
  auto face = [&](const V3f& corner, const V3f& u, const V3f& v, const V3f& facing, const C3f& radiance, int n) {
    if ((u.cross(v)).dot(facing) > 0) test::add_quad(scene, corner, corner + u, corner + u + v, corner + v, m);
    else test::add_quad(scene, corner, corner + v, corner + u + v, corner + u, m);
    add_surfels(surfels, corner, u, v, facing, radiance, n);
  };
  for (int axis = 0; axis < 3; ++axis) {
    for (const float sign : {-1.f, 1.f}) {
      V3f n(0.f), u(0.f), v(0.f);
      n[axis] = sign;
      u[(axis + 1) % 3] = 2.f;
      v[(axis + 2) % 3] = 2.f;
      face(n - (u + v) * 0.5f, u, v, -n, axis == 1 && sign < 0 ? C3f(0.2f) : C3f(1.f), 32);
    }
  }
  const V3f lo(-0.3f, -1.f, -0.3f), size(0.6f, 0.4f, 0.6f);
  for (int axis = 0; axis < 3; ++axis) {
    for (const float sign : {-1.f, 1.f}) {
      if (axis == 1 && sign < 0) continue;  // it stands on the floor
      V3f n(0.f), u(0.f), v(0.f);
      n[axis] = sign;
      u[(axis + 1) % 3] = size[(axis + 1) % 3];
      v[(axis + 2) % 3] = size[(axis + 2) % 3];
      V3f corner = lo;
      if (sign > 0) corner[axis] += size[axis];
      face(corner, u, v, n, C3f(0.f), 8);
    }
  }
  const RayScene rays(scene);
  testing::TempDir tmp;
  size_t subtrees = 0;
  const auto tree = open_with_regions(scene, rays, 64, surfels, tmp.path() / "set", subtrees);
  ASSERT_GE(subtrees, 2u);
  // A row of receivers on the floor across the block, facing up.
  const std::vector<Receiver> row = floor_row(64, -0.9f, 0.9f, -0.999f, 0.05f);
  GatherOptions options;
  const GatherBatch full = gather_receivers(*tree, row, options, {}, nullptr, &rays);
  const GatherBatch interpolated = gather_interpolated(*tree, row, options, 0.1f, {}, nullptr, &rays);
  int under = 0;
  for (size_t i = 0; i < row.size(); ++i) {
    const bool inside = std::abs(row[i].position.x) < 0.3f;
    under += inside;
    if (inside) {
      EXPECT_EQ(full.results[i].irradiance, C3f(0.f)) << i;
    } else {
      // Lit by the room's walls, interpolated or not.
      EXPECT_GT(full.results[i].irradiance.x, 0.1f) << i;
      EXPECT_GT(interpolated.results[i].irradiance.x, 0.5f * full.results[i].irradiance.x) << i;
    }
  }
  EXPECT_GT(under, 0);
}

}  // namespace
}  // namespace pbgi::service
