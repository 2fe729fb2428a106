// Instancing through the USD reader process: native instances and a
// PointInstancer arrive as prototypes (geometry once) + instance transforms,
// and the scene they make equals the same stage read with
// IngestOptions::flatten_instances (every copy expanded by the reader):
// same triangles in world space, same ray hits, same surfel area. The chunk
// store keeps the instancing.
#include "server/ingest/chunk_store.h"
#include "server/ingest/usd_ingest.h"
#include "server/scene/ray_scene.h"
#include "server/surfels/surfels.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

// Native instances (one mirrored, one with its own material binding) of a
// two-gprim prototype, and a PointInstancer with two prototypes; a ground.
const char* kScene = R"(#usda 1.0
(
    upAxis = "Y"
    metersPerUnit = 1
)
class Xform "Tree"
{
    def Mesh "Trunk"
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [4, 4]
        int[] faceVertexIndices = [0, 1, 2, 3, 4, 5, 6, 7]
        point3f[] points = [(-0.2, 0, 0), (0.2, 0, 0), (0.2, 2, 0), (-0.2, 2, 0), (0, 0, -0.2), (0, 0, 0.2), (0, 2, 0.2), (0, 2, -0.2)]
    }
    def Cone "Crown"
    {
        double height = 2
        double radius = 1
        token axis = "Y"
        double3 xformOp:translate = (0, 3, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
def Material "Red"
{
    token outputs:surface.connect = </Red/S.outputs:surface>
    def Shader "S"
    {
        uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor = (0.8, 0.1, 0.1)
        token outputs:surface
    }
}
def Xform "World"
{
    def Mesh "Ground"
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 3, 2, 1]
        point3f[] points = [(-20, 0, -20), (20, 0, -20), (20, 0, 20), (-20, 0, 20)]
    }
    def Xform "T1" (instanceable = true
        prepend references = </Tree>)
    {
        double3 xformOp:translate = (-5, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Xform "T2" (instanceable = true
        prepend references = </Tree>)
    {
        double3 xformOp:translate = (5, 0, 2)
        float3 xformOp:scale = (-1, 1.5, 1)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
    }
    def Xform "T3" (instanceable = true
        prepend apiSchemas = ["MaterialBindingAPI"]
        prepend references = </Tree>)
    {
        rel material:binding = </Red>
        double3 xformOp:translate = (0, 0, -6)
        float xformOp:rotateY = 40
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateY"]
    }
    def PointInstancer "Rocks"
    {
        rel prototypes = [</World/Rocks/P/Box>, </World/Rocks/P/Ball>]
        int[] protoIndices = [0, 1, 0, 1, 0]
        point3f[] positions = [(8, 0.5, 8), (-8, 0.5, 8), (8, 0.5, -8), (-8, 0.5, -8), (0, 0.5, 9)]
        float3[] scales = [(1, 1, 1), (1, 2, 1), (2, 1, 1), (1, 1, 1), (-1, 1, 1)]
        def Scope "P"
        {
            def Cube "Box"
            {
                double size = 1
            }
            def Sphere "Ball"
            {
                double radius = 0.5
            }
        }
    }
}
)";

struct Triangle {
  V3f c, n;  // centroid and unit normal in world space
};

std::vector<Triangle> world_triangles(const Scene& s) {
  std::vector<Triangle> out;
  for (uint32_t id = 0; id < s.triangle_count(); ++id) {
    const TriangleRef r = s.triangle(id);
    const V3f a = r.position(0), b = r.position(1), c = r.position(2);
    out.push_back({(a + b + c) / 3.f, (b - a).cross(c - a).normalized()});
  }
  return out;
}

// The largest distance from a triangle of `a` to the nearest triangle of
// `b` with the same facing (normals within ~2.5 degrees): 0 when the two
// are the same set of oriented triangles, whatever their order.
float largest_mismatch(const std::vector<Triangle>& a, const std::vector<Triangle>& b) {
  float worst = 0.f;
  for (const Triangle& t : a) {
    float best = std::numeric_limits<float>::infinity();
    for (const Triangle& u : b)
      if (t.n.dot(u.n) > 0.999f) best = std::min(best, (t.c - u.c).length2());
    worst = std::max(worst, std::sqrt(best));
  }
  return worst;
}

class InstancingIngest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() / ("pbgi_instancing_ingest_" + std::to_string(getpid())));
    fs::create_directories(*dir_);
    std::ofstream(*dir_ / "scene.usda") << kScene;
    instanced_ = new Scene(read_usd_scene(*dir_ / "scene.usda", IngestOptions{}));
    IngestOptions flat;
    flat.flatten_instances = true;
    flattened_ = new Scene(read_usd_scene(*dir_ / "scene.usda", flat));
  }
  static void TearDownTestSuite() {
    delete instanced_;
    delete flattened_;
    std::error_code ec;
    fs::remove_all(*dir_, ec);
    delete dir_;
  }
  static fs::path* dir_;
  static Scene* instanced_;
  static Scene* flattened_;
};
fs::path* InstancingIngest::dir_ = nullptr;
Scene* InstancingIngest::instanced_ = nullptr;
Scene* InstancingIngest::flattened_ = nullptr;

TEST_F(InstancingIngest, PrototypesAreSentOnceAndPlacedByInstances) {
  const Scene& s = *instanced_;
  // Tree twice (T3 binds another material, so its gprims differ), Box, Ball.
  ASSERT_EQ(s.prototypes.size(), 4u);
  EXPECT_EQ(s.instances.size(), 3u + 5u);
  EXPECT_TRUE(flattened_->prototypes.empty());
  EXPECT_TRUE(flattened_->instances.empty());
  // The world soup holds the ground only.
  EXPECT_EQ(s.triangles.triangle_count(), 2u);
  size_t once = s.triangles.triangle_count();
  for (const Prototype& p : s.prototypes) once += p.triangles.triangle_count();
  EXPECT_LT(once, s.triangle_count());
  EXPECT_NE(s.content_hash, flattened_->content_hash);  // another stream: caches must not mix them
}

TEST_F(InstancingIngest, SameWorldTrianglesAsFlattened) {
  const auto a = world_triangles(*instanced_), b = world_triangles(*flattened_);
  ASSERT_EQ(a.size(), b.size());
  // Both ways: the same oriented triangles (winding kept through mirrors).
  EXPECT_LT(largest_mismatch(a, b), 1e-4f);
  EXPECT_LT(largest_mismatch(b, a), 1e-4f);
  const Box3f ba = instanced_->bounds(), bb = flattened_->bounds();
  EXPECT_NEAR((ba.min - bb.min).length(), 0.f, 1e-4f);
  EXPECT_NEAR((ba.max - bb.max).length(), 0.f, 1e-4f);
}

TEST_F(InstancingIngest, RaysAndMaterialsMatchFlattened) {
  const RayScene ra(*instanced_), rb(*flattened_);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  int hits = 0, red = 0;
  for (int i = 0; i < 3000; ++i) {
    const V3f o(12.f * u(rng), 6.f + 3.f * u(rng), 12.f * u(rng));
    const V3f d = V3f(0.4f * u(rng), -1.f, 0.4f * u(rng)).normalized();
    const Hit a = ra.intersect(o, d), b = rb.intersect(o, d);
    ASSERT_EQ(a.valid(), b.valid()) << i;
    if (!a.valid()) continue;
    ++hits;
    EXPECT_NEAR(a.t, b.t, 1e-3f) << i;
    EXPECT_NEAR((a.geometric_normal - b.geometric_normal).length(), 0.f, 1e-3f) << i;
    const Material& ma = instanced_->materials[instanced_->triangle(a.triangle).material()];
    const Material& mb = flattened_->materials[flattened_->triangle(b.triangle).material()];
    EXPECT_EQ(ma.albedo, mb.albedo) << i;
    red += ma.albedo == C3f(0.8f, 0.1f, 0.1f);
  }
  EXPECT_GT(hits, 2000);
  EXPECT_GT(red, 0);  // T3's own binding reached its (separate) prototype
}

TEST_F(InstancingIngest, SurfelsCoverTheSameArea) {
  SurfelOptions o;
  o.spacing = 0.1f;
  const std::vector<Surfel> a = sample_surfels(*instanced_, o), b = sample_surfels(*flattened_, o);
  double area_a = 0, area_b = 0;
  for (const Surfel& s : a) area_a += s.area();
  for (const Surfel& s : b) area_b += s.area();
  EXPECT_NEAR(area_a, area_b, 1e-4 * area_b);  // area is conserved exactly by both
  // Counts are random per triangle (and triangle ids are in another order):
  // equal within sampling noise.
  EXPECT_NEAR(double(a.size()), double(b.size()), 5.0 * std::sqrt(double(b.size())));
}

TEST_F(InstancingIngest, ChunkStoreKeepsPrototypesAndInstances) {
  ChunkStoreOptions o;
  o.directory = *dir_ / "store";
  const ChunkStore store(o);
  store.save("k", *instanced_);
  const std::optional<Scene> back = store.load("k");
  ASSERT_TRUE(back);
  ASSERT_EQ(back->prototypes.size(), instanced_->prototypes.size());
  ASSERT_EQ(back->instances.size(), instanced_->instances.size());
  EXPECT_EQ(back->triangle_count(), instanced_->triangle_count());
  for (size_t k = 0; k < back->instances.size(); ++k) {
    EXPECT_EQ(back->instances[k].prototype, instanced_->instances[k].prototype);
    EXPECT_EQ(back->instances[k].local_to_world, instanced_->instances[k].local_to_world);
  }
  // Within Draco's quantization (16 bits over a chunk of at most a few metres).
  const auto a = world_triangles(*back), b = world_triangles(*instanced_);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_LT(largest_mismatch(a, b), 1e-3f);
}

}  // namespace
}  // namespace pbgi
