// Subdivision meshes through the whole ingest (USD reader process + daemon
// refinement): USD's subdivision attributes reach OpenSubdiv, the cage is
// placed and wound in world space, and the USD Working Group's subdivision
// assets read without subdivision warnings.
#include "server/ingest/usd_ingest.h"

#include <gtest/gtest.h>

#include "tests/server/ingest/scratch_files.h"
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

using test::temp_dir;
using test::write_file;

// A unit cube mesh [-0.5, 0.5]^3 named `name` with extra attribute lines.
std::string cube(const std::string& name, const std::string& extra = "") {
  return "    def Mesh \"" + name + R"("
    {
        int[] faceVertexCounts = [4, 4, 4, 4, 4, 4]
        int[] faceVertexIndices = [0, 1, 3, 2, 2, 3, 5, 4, 4, 5, 7, 6, 6, 7, 1, 0, 1, 7, 5, 3, 6, 0, 2, 4]
        point3f[] points = [(-0.5, -0.5, 0.5), (0.5, -0.5, 0.5), (-0.5, 0.5, 0.5), (0.5, 0.5, 0.5), (-0.5, 0.5, -0.5), (0.5, 0.5, -0.5), (-0.5, -0.5, -0.5), (0.5, -0.5, -0.5)]
)" + extra + "    }\n";
}

const char* kSharpEdges = R"(        int[] creaseIndices = [0, 1, 3, 2, 0, 4, 5, 7, 6, 4, 0, 6, 1, 7, 3, 5, 2, 4]
        int[] creaseLengths = [5, 5, 2, 2, 2, 2]
        float[] creaseSharpnesses = [10, 10, 10, 10, 10, 10]
)";

// One stage with a mesh per case, read once for the suite.
std::string subdiv_scene() {
  return std::string(R"(#usda 1.0
(
    metersPerUnit = 1
    upAxis = "Y"
)
def Material "Red"
{
    token outputs:surface.connect = </Red/Surface.outputs:surface>
    def Shader "Surface"
    {
        uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor = (0.8, 0.1, 0.1)
        token outputs:surface
    }
}
def Xform "W"
{
)") + cube("Default") +
         cube("None", "        uniform token subdivisionScheme = \"none\"\n") +
         cube("Bilinear", "        uniform token subdivisionScheme = \"bilinear\"\n") +
         cube("Sharp", kSharpEdges) +
         cube("QuadLoop", "        uniform token subdivisionScheme = \"loop\"\n") + R"(
    def Mesh "Tetra"
    {
        uniform token subdivisionScheme = "loop"
        int[] faceVertexCounts = [3, 3, 3, 3]
        int[] faceVertexIndices = [0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2]
        point3f[] points = [(1, 1, 11), (1, -1, 9), (-1, 1, 9), (-1, -1, 11)]
    }
    def Xform "Mirror"
    {
        double3 xformOp:translate = (10, 0, 0)
        double3 xformOp:scale = (-2, 2, 2)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
)" + cube("RightHanded") + cube("LeftHanded", "        uniform token orientation = \"leftHanded\"\n") +
         R"(    }
)" + cube("LeftHanded", "        uniform token orientation = \"leftHanded\"\n") + cube("Subsets", R"(
        def GeomSubset "Top" (
            prepend apiSchemas = ["MaterialBindingAPI"]
        )
        {
            uniform token elementType = "face"
            uniform token familyName = "materialBind"
            int[] indices = [0]
            rel material:binding = </Red>
        }
)") + "}\n";
}

class SubdivIngest : public ::testing::Test {
 protected:
  static const Scene& scene() {
    static const Scene s = read_usd_scene(write_file("subdiv.usda", subdiv_scene()), IngestOptions{});
    return s;
  }

  static std::vector<size_t> triangles_of(const Scene& s, const std::string& prim) {
    std::vector<size_t> out;
    const auto it = std::find(s.triangles.mesh_paths.begin(), s.triangles.mesh_paths.end(), prim);
    if (it == s.triangles.mesh_paths.end()) return out;
    const uint32_t mesh = static_cast<uint32_t>(it - s.triangles.mesh_paths.begin());
    for (size_t t = 0; t < s.triangles.triangle_count(); ++t)
      if (s.triangles.mesh[t] == mesh) out.push_back(t);
    return out;
  }

  static std::vector<V3f> points_of(const Scene& s, const std::string& prim) {
    std::vector<V3f> out;
    for (size_t t : triangles_of(s, prim))
      for (int k = 0; k < 3; ++k) out.push_back(s.triangles.positions[s.triangles.indices[3 * t + k]]);
    return out;
  }

  static size_t warnings_naming(const Scene& s, const std::string& prim, const std::string& word) {
    return std::count_if(s.warnings.begin(), s.warnings.end(), [&](const std::string& w) {
      return w.find(prim) != std::string::npos && w.find(word) != std::string::npos;
    });
  }

  static float box_distance(const V3f& p, const V3f& centre) {
    const V3f d = p - centre;
    return std::max({std::abs(d.x), std::abs(d.y), std::abs(d.z)});
  }

  // Triangles wind counter-clockwise around their vertex normals, and the
  // normals point away from `centre` (towards it if `facing` is -1).
  static void expect_outward(const Scene& s, const std::string& prim, const V3f& centre, float facing = 1.f) {
    const TriangleSoup& soup = s.triangles;
    ASSERT_EQ(soup.normals.size(), soup.positions.size());
    const auto triangles = triangles_of(s, prim);
    ASSERT_FALSE(triangles.empty()) << prim;
    for (size_t t : triangles) {
      const V3f a = soup.positions[soup.indices[3 * t]], b = soup.positions[soup.indices[3 * t + 1]],
                c = soup.positions[soup.indices[3 * t + 2]];
      const V3f g = (b - a).cross(c - a);
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = soup.indices[3 * t + k];
        EXPECT_GT(g.dot(soup.normals[v]), 0.f) << prim << " triangle " << t;
        EXPECT_GT(facing * soup.normals[v].dot(soup.positions[v] - centre), 0.f) << prim << " triangle " << t;
      }
    }
  }
};

TEST_F(SubdivIngest, CatmullClarkIsUsdsDefaultAndIsRefined) {
  // No subdivisionScheme authored; no target: level 2.
  EXPECT_EQ(triangles_of(scene(), "/W/Default").size(), 2u * 6 * 16);
  for (const V3f& p : points_of(scene(), "/W/Default")) EXPECT_LT(box_distance(p, V3f(0.f)), 0.5f - 1e-3f);
  expect_outward(scene(), "/W/Default", V3f(0.f));
  for (const std::string& w : scene().warnings) {  // only QuadLoop reports (below)
    if (w.find("/W/QuadLoop") != std::string::npos) continue;
    EXPECT_EQ(w.find("subdivision"), std::string::npos) << w;
  }
}

TEST_F(SubdivIngest, SchemeNoneIsReadAsAuthored) {
  const auto points = points_of(scene(), "/W/None");
  EXPECT_EQ(points.size(), 3u * 12);
  for (const V3f& p : points) {
    EXPECT_EQ(std::abs(p.x), 0.5f);
    EXPECT_EQ(std::abs(p.y), 0.5f);
    EXPECT_EQ(std::abs(p.z), 0.5f);
  }
}

TEST_F(SubdivIngest, BilinearStaysOnTheCageFaces) {
  EXPECT_EQ(triangles_of(scene(), "/W/Bilinear").size(), 2u * 6 * 16);
  for (const V3f& p : points_of(scene(), "/W/Bilinear")) EXPECT_NEAR(box_distance(p, V3f(0.f)), 0.5f, 1e-6f);
  expect_outward(scene(), "/W/Bilinear", V3f(0.f));
}

TEST_F(SubdivIngest, UsdCreaseChainsKeepTheCube) {
  for (const V3f& p : points_of(scene(), "/W/Sharp")) EXPECT_NEAR(box_distance(p, V3f(0.f)), 0.5f, 1e-5f);
  expect_outward(scene(), "/W/Sharp", V3f(0.f));
}

TEST_F(SubdivIngest, LoopOnQuadsIsAnErrorNamingThePrimAndFallsBackToTheCage) {
  EXPECT_EQ(warnings_naming(scene(), "/W/QuadLoop", "'loop' needs triangles"), 1u);
  EXPECT_EQ(triangles_of(scene(), "/W/QuadLoop").size(), 12u);
}

TEST_F(SubdivIngest, LoopRefinesTheTetrahedron) {
  EXPECT_EQ(triangles_of(scene(), "/W/Tetra").size(), 4u * 16);
  expect_outward(scene(), "/W/Tetra", V3f(0.f, 0.f, 10.f));
}

TEST_F(SubdivIngest, CageIsPlacedAndWoundInWorldSpace) {
  // The cube's faces are counter-clockwise seen from outside: rightHanded
  // they face out, leftHanded in; a mirroring transform changes neither
  // (as for meshes that are not subdivided).
  const V3f centre(10.f, 0.f, 0.f);
  for (const V3f& p : points_of(scene(), "/W/Mirror/RightHanded")) EXPECT_LT(box_distance(p, centre), 1.f - 2e-3f);
  expect_outward(scene(), "/W/Mirror/RightHanded", centre);
  expect_outward(scene(), "/W/Mirror/LeftHanded", centre, -1.f);
  expect_outward(scene(), "/W/LeftHanded", V3f(0.f), -1.f);
}

TEST_F(SubdivIngest, GeomSubsetMaterialsFollowTheRefinedFaces) {
  const Scene& s = scene();
  std::set<uint32_t> materials;
  size_t red = 0;
  for (size_t t : triangles_of(s, "/W/Subsets")) {
    materials.insert(s.triangles.material[t]);
    red += s.materials[s.triangles.material[t]].prim_path == "/Red";
  }
  EXPECT_EQ(materials.size(), 2u);
  EXPECT_EQ(red, 2u * 16);  // face 0 at level 2
}

TEST(SubdivIngestOptions, TargetEdgeLengthIsInWorldUnits) {
  const fs::path path = write_file("scaled.usda", R"(#usda 1.0
def Xform "Big"
{
    double3 xformOp:scale = (2, 2, 2)
    uniform token[] xformOpOrder = ["xformOp:scale"]
)" + cube("Cube") + "}\n" + R"(def Xform "Small"
{
)" + cube("Cube") + "}\n");
  IngestOptions options;
  options.target_edge_length = 0.5f;  // cube edges: 2 (Big), 1 (Small)
  const Scene scene = read_usd_scene(path, options);
  std::vector<size_t> per_mesh(scene.triangles.mesh_paths.size(), 0);
  for (const uint32_t m : scene.triangles.mesh) ++per_mesh[m];
  ASSERT_EQ(scene.triangles.mesh_paths.size(), 2u);
  EXPECT_EQ(scene.triangles.mesh_paths[0], "/Big/Cube");
  EXPECT_EQ(per_mesh[0], 2u * 6 * 16);  // level 2
  EXPECT_EQ(per_mesh[1], 2u * 6 * 4);   // level 1
  // Halving the target adds a level to each.
  options.target_edge_length = 0.25f;
  const Scene finer = read_usd_scene(path, options);
  EXPECT_EQ(finer.triangles.triangle_count(), 2u * 6 * (64 + 16));
  EXPECT_NE(finer.content_hash, scene.content_hash);
  // Capped with a warning naming the mesh.
  options.target_edge_length = 1e-3f;
  options.max_subdivision_level = 3;
  const Scene capped = read_usd_scene(path, options);
  EXPECT_EQ(capped.triangles.triangle_count(), 2u * 2 * 6 * 64);
  EXPECT_EQ(std::count_if(capped.warnings.begin(), capped.warnings.end(),
                          [](const std::string& w) { return w.find("capped at level 3") != std::string::npos; }),
            2);
}

TEST(SubdivIngestOptions, WithoutATargetEachCageIsBoundedByTheSpacingOfAllTheScenesCages) {
  // A unit cube beside a flat 1000 x 1000 cage, 10,000 surfels: the scene's
  // spacing (~10) is far wider than the cube's alone (~0.025, which needs
  // the default level 2); the reader sends the cages' total area first, so
  // the cube stays at its cage.
  const fs::path path = write_file("wide.usda", R"(#usda 1.0
def Xform "W"
{
)" + cube("Cube") + R"(    def Mesh "Ground"
    {
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(-500, -1, -500), (-500, -1, 500), (500, -1, 500), (500, -1, -500)]
    }
}
)");
  IngestOptions options;
  options.target_surfels = 10000;
  const Scene scene = read_usd_scene(path, options);
  std::vector<size_t> per_mesh(scene.triangles.mesh_paths.size(), 0);
  for (const uint32_t m : scene.triangles.mesh) ++per_mesh[m];
  ASSERT_EQ(scene.triangles.mesh_paths.size(), 2u);
  EXPECT_EQ(scene.triangles.mesh_paths[0], "/W/Cube");
  EXPECT_EQ(per_mesh[0], 2u * 6);  // level 0 (per-cage spacing: level 2, 2 * 6 * 16)
  // Alone, the cube is bounded by its own spacing.
  const Scene alone = read_usd_scene(write_file("alone.usda", "#usda 1.0\n" + cube("Cube")), options);
  EXPECT_EQ(alone.triangles.triangle_count(), 2u * 6 * 16);
}

TEST(SubdivTestScene, ReadsEverySurfaceRefinedAndResting) {
  // scenes/subdiv_test.usda: the Cornell room with five subdivision meshes.
  const Scene scene = read_usd_scene(fs::path(PBGI_TEST_SOURCE_DIR) / "scenes/subdiv_test.usda", IngestOptions{});
  EXPECT_TRUE(scene.warnings.empty()) << scene.warnings.front();
  const auto& paths = scene.triangles.mesh_paths;
  std::vector<size_t> per_mesh(paths.size(), 0);
  std::vector<float> lowest(paths.size(), 1e9f);
  for (size_t t = 0; t < scene.triangles.triangle_count(); ++t) {
    const uint32_t m = scene.triangles.mesh[t];
    ++per_mesh[m];
    for (int k = 0; k < 3; ++k)
      lowest[m] = std::min(lowest[m], scene.triangles.positions[scene.triangles.indices[3 * t + k]].y);
  }
  auto count = [&](const std::string& prim) {
    const auto it = std::find(paths.begin(), paths.end(), prim);
    return it == paths.end() ? size_t(0) : per_mesh[it - paths.begin()];
  };
  auto low = [&](const std::string& prim) { return lowest[std::find(paths.begin(), paths.end(), prim) - paths.begin()]; };
  EXPECT_EQ(count("/World/TallBox"), 0u);  // deactivated over the Cornell layer
  EXPECT_EQ(count("/World/Room/Floor"), 2u);
  for (const char* cube : {"/World/Subdiv/SmoothCube", "/World/Subdiv/CreasedCube", "/World/Subdiv/CornerCube"}) {
    EXPECT_EQ(count(cube), 2u * 6 * 16) << cube;
    EXPECT_GE(low(cube), 0.f) << cube;
    EXPECT_LT(low(cube), 2e-3f) << cube;
  }
  EXPECT_EQ(low("/World/Subdiv/CreasedCube"), 0.f);  // its infinitely sharp bottom stays flat
  EXPECT_EQ(count("/World/Subdiv/LoopTetra"), 4u * 16);
  EXPECT_EQ(count("/World/Subdiv/Saddle"), 2u * 3 * 16);  // 4 faces, one a hole
}

// The USD Working Group's subdivision assets (creases, corners, holes).
const fs::path kSubdivDir = "/work/shared/scenes/usd-wg/full_assets/SubdivisionSurfaces";

void expect_no_subdivision_warnings(const Scene& scene) {
  for (const std::string& w : scene.warnings) {
    EXPECT_EQ(w.find("subdivision"), std::string::npos) << w;
    EXPECT_EQ(w.find("OpenSubdiv"), std::string::npos) << w;
  }
}

TEST(UsdWgSubdivision, PyramidReadsRefined) {
  if (!fs::is_directory(kSubdivDir)) GTEST_SKIP() << kSubdivDir << " is absent";
  const Scene scene = read_usd_scene(kSubdivDir / "Pyramid/Pyramid.usd", IngestOptions{});
  expect_no_subdivision_warnings(scene);
  EXPECT_EQ(scene.triangles.triangle_count(), 2u * 24 * 16);  // 24 quads at level 2
}

TEST(UsdWgSubdivision, PyramidHolesVariantLeavesTheHolesOut) {
  if (!fs::is_directory(kSubdivDir)) GTEST_SKIP() << kSubdivDir << " is absent";
  const fs::path path = write_file("holes.usda", R"(#usda 1.0
def "Holes" (
    prepend references = @)" + (kSubdivDir / "Pyramid/Pyramid.usd").string() +
                                                     R"(@
    variants = {
        string geo = "quad_holes"
    }
)
{
}
)");
  const Scene scene = read_usd_scene(path, IngestOptions{});
  expect_no_subdivision_warnings(scene);
  EXPECT_GT(scene.triangles.triangle_count(), 0u);
  EXPECT_LT(scene.triangles.triangle_count(), 2u * 24 * 16);
}

TEST(UsdWgSubdivision, SpinningPyramidsReadWithCreasesAndCorners) {
  if (!fs::is_directory(kSubdivDir)) GTEST_SKIP() << kSubdivDir << " is absent";
  const Scene scene = read_usd_scene(kSubdivDir / "Creases_SpinningPyramids.usda", IngestOptions{});
  expect_no_subdivision_warnings(scene);
  // The pyramids are native instances: each its own prototype (cage
  // refined in prototype space), placed by an instance; walked in world
  // space through Scene::triangle().
  ASSERT_EQ(scene.mesh_count(), 3u);
  // The three pyramids differ only by their tags: their surfaces must differ.
  std::vector<double> extent(3, 0.0);
  std::vector<V3f> centre(3, V3f(0.f));
  std::vector<size_t> count(3, 0);
  for (uint32_t t = 0; t < scene.triangle_count(); ++t) {
    const uint32_t m = scene.mesh_ordinal(t);
    for (int k = 0; k < 3; ++k) centre[m] += scene.triangle(t).position(k);
    count[m] += 3;
  }
  for (size_t m = 0; m < 3; ++m) centre[m] /= float(count[m]);
  for (uint32_t t = 0; t < scene.triangle_count(); ++t) {
    const uint32_t m = scene.mesh_ordinal(t);
    for (int k = 0; k < 3; ++k)
      extent[m] = std::max(extent[m], double((scene.triangle(t).position(k) - centre[m]).length()));
  }
  EXPECT_GT(std::abs(extent[0] - extent[1]) + std::abs(extent[1] - extent[2]), 1e-3) << extent[0] << " " << extent[1];
}

}  // namespace
}  // namespace pbgi
