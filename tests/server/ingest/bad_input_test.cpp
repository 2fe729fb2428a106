// Bad input (issue "Scene ingest"): every kind of broken data gives a
// warning naming the prim and the file that defines it, and the prim is
// repaired or skipped; the scene is never lost and nothing crashes.
#include "server/ingest/usd_ingest.h"

#include "common/errors.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

fs::path temp_dir() {
  static const struct Dir {
    fs::path path = fs::temp_directory_path() / ("pbgi_bad_input_test_" + std::to_string(getpid()));
    Dir() { fs::create_directories(path); }
    ~Dir() {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  } dir;
  return dir.path;
}

fs::path write_file(const std::string& name, const std::string& text) {
  const fs::path path = temp_dir() / name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

// One polygon mesh prim (subdivisionScheme none unless `scheme` is given).
std::string mesh(const std::string& name, const std::string& counts, const std::string& indices,
                 const std::string& points, const std::string& extra = "", const std::string& scheme = "none") {
  return "def Mesh \"" + name + "\"\n{\n    uniform token subdivisionScheme = \"" + scheme +
         "\"\n    int[] faceVertexCounts = [" + counts + "]\n    int[] faceVertexIndices = [" + indices +
         "]\n    point3f[] points = [" + points + "]\n" + extra + "}\n";
}

// Two unit quads side by side in z = 0: faces 0 (x in [0, 1]) and 1 (x in [1, 2]).
const char* kTwoQuadPoints = "(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)";
const char* kTwoQuadIndices = "0, 1, 4, 3, 1, 2, 5, 4";

std::string bad_scene() {
  std::string s = "#usda 1.0\n";
  // NaN and Inf points: only the faces using them go.
  s += mesh("NanPoints", "4, 4", kTwoQuadIndices,
            "(0, 0, 0), (1, 0, 0), (nan, 0, 0), (0, 1, 0), (1, 1, 0), (2, inf, 0)");
  // Out-of-range and negative indices: face 1 goes.
  s += mesh("BadIndices", "4, 4", "0, 1, 4, 3, 1, 9, 5, -2", kTwoQuadPoints);
  // Face 1 repeats a vertex (zero area), face 2 is collinear, face 3 has
  // two vertices; face 0 is sound.
  s += mesh("Degenerate", "3, 3, 3, 2", "0, 1, 4, 1, 1, 4, 0, 1, 2, 3, 4",
            "(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)");
  // Primvars of the wrong size are ignored, the mesh is read.
  s += mesh("BadPrimvars", "4, 4", kTwoQuadIndices, kTwoQuadPoints,
            "    normal3f[] normals = [(0, 0, 1), (0, 0, 1)] (\n        interpolation = \"vertex\"\n    )\n"
            "    color3f[] primvars:displayColor = [(1, 0, 0), (0, 1, 0), (0, 0, 1)] (\n"
            "        interpolation = \"vertex\"\n    )\n");
  // Three quads around one edge (1-4): non-manifold, read as authored.
  s += mesh("Fin", "4, 4, 4", "0, 1, 4, 3, 1, 2, 5, 4, 1, 6, 7, 4",
            std::string(kTwoQuadPoints) + ", (1, 0, 1), (1, 1, 1)");
  // The same fin as a Catmull-Clark cage: refined (OpenSubdiv handles
  // non-manifold edges), reported.
  s += mesh("FinCage", "4, 4, 4", "0, 1, 4, 3, 1, 2, 5, 4, 1, 6, 7, 4",
            std::string(kTwoQuadPoints) + ", (1, 0, 1), (1, 1, 1)", "", "catmullClark");
  // A cage with a broken face: read as its repaired, unrefined cage.
  s += mesh("BadCage", "4, 4", "0, 1, 4, 3, 1, 2, 5, 44", kTwoQuadPoints, "", "catmullClark");
  // Counts that do not match the indices cannot be repaired: skipped.
  s += mesh("Miscounted", "4, 4", "0, 1, 4, 3, 1, 2, 5", kTwoQuadPoints);
  s += mesh("Good", "4", "0, 1, 4, 3", kTwoQuadPoints);
  return s;
}

class BadInput : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    path_ = new fs::path(write_file("bad.usda", bad_scene()));
    scene_ = new Scene(read_usd_scene(*path_, IngestOptions{}));
  }
  static void TearDownTestSuite() {
    delete scene_;
    delete path_;
  }
  static const Scene& scene() { return *scene_; }

  static std::vector<size_t> triangles_of(const std::string& prim) {
    std::vector<size_t> out;
    const TriangleSoup& t = scene().triangles;
    for (size_t i = 0; i < t.triangle_count(); ++i)
      if (t.mesh_paths[t.mesh[i]] == prim) out.push_back(i);
    return out;
  }
  // Warnings that start with the prim path, contain `text` and name the file.
  static size_t warnings(const std::string& prim, const std::string& text) {
    return std::count_if(scene().warnings.begin(), scene().warnings.end(), [&](const std::string& w) {
      return w.rfind(prim + ": ", 0) == 0 && w.find(text) != std::string::npos &&
             w.find(path_->string()) != std::string::npos;
    });
  }
  static float x_center(size_t t) {
    const TriangleSoup& s = scene().triangles;
    return (s.positions[s.indices[3 * t]].x + s.positions[s.indices[3 * t + 1]].x +
            s.positions[s.indices[3 * t + 2]].x) / 3.f;
  }

  static fs::path* path_;
  static Scene* scene_;
};
fs::path* BadInput::path_ = nullptr;
Scene* BadInput::scene_ = nullptr;

TEST_F(BadInput, EveryVertexIsFinite) {
  for (const V3f& p : scene().triangles.positions) ASSERT_TRUE(std::isfinite(p.x + p.y + p.z));
  for (const V3f& n : scene().triangles.normals) ASSERT_TRUE(std::isfinite(n.x + n.y + n.z));
}

TEST_F(BadInput, FacesUsingNonFinitePointsAreSkipped) {
  // Face 0 uses no bad point; face 1 uses (nan, 0, 0) and (2, inf, 0).
  const auto tris = triangles_of("/NanPoints");
  ASSERT_EQ(tris.size(), 2u);
  for (size_t t : tris) EXPECT_LT(x_center(t), 1.f);
  EXPECT_EQ(warnings("/NanPoints", "NaN or infinite"), 1u);
}

TEST_F(BadInput, FacesWithOutOfRangeIndicesAreSkipped) {
  const auto tris = triangles_of("/BadIndices");
  ASSERT_EQ(tris.size(), 2u);
  for (size_t t : tris) EXPECT_LT(x_center(t), 1.f);
  EXPECT_EQ(warnings("/BadIndices", "faceVertexIndices outside [0, 6)"), 1u);
}

TEST_F(BadInput, ZeroAreaAndShortFacesAreDropped) {
  EXPECT_EQ(triangles_of("/Degenerate").size(), 1u);
  EXPECT_EQ(warnings("/Degenerate", "2 zero-area or degenerate triangles dropped"), 1u);
  EXPECT_EQ(warnings("/Degenerate", "fewer than 3 vertices"), 1u);
  for (size_t t = 0; t < scene().triangles.triangle_count(); ++t) {
    const TriangleSoup& s = scene().triangles;
    const V3f a = s.positions[s.indices[3 * t]], b = s.positions[s.indices[3 * t + 1]],
              c = s.positions[s.indices[3 * t + 2]];
    EXPECT_GT((b - a).cross(c - a).length(), 0.f) << s.mesh_paths[s.mesh[t]];
  }
}

TEST_F(BadInput, PrimvarsOfTheWrongSizeAreIgnored) {
  EXPECT_EQ(triangles_of("/BadPrimvars").size(), 4u);
  EXPECT_EQ(warnings("/BadPrimvars", "normals"), 1u);
  EXPECT_EQ(warnings("/BadPrimvars", "displayColor"), 1u);
}

TEST_F(BadInput, NonManifoldMeshesAreReadAndReported) {
  EXPECT_EQ(triangles_of("/Fin").size(), 6u);
  EXPECT_EQ(warnings("/Fin", "non-manifold topology: 1 edges"), 1u);
  EXPECT_GT(triangles_of("/FinCage").size(), 6u);  // refined
  EXPECT_EQ(warnings("/FinCage", "non-manifold"), 1u);
}

TEST_F(BadInput, BrokenCagesAreReadAsTheirRepairedCage) {
  EXPECT_EQ(triangles_of("/BadCage").size(), 2u);
  EXPECT_EQ(warnings("/BadCage", "repaired control cage"), 1u);
}

TEST_F(BadInput, UnrepairableMeshesAreSkippedNamingThePrim) {
  EXPECT_TRUE(triangles_of("/Miscounted").empty());
  EXPECT_EQ(warnings("/Miscounted", "faceVertexCounts sum to 8"), 1u);
  EXPECT_EQ(triangles_of("/Good").size(), 2u);
}

// Random garbage meshes (deterministic): whatever the counts, indices,
// points and normals, the scene is read, every triangle is valid and every
// vertex finite; no prim takes the scene down.
TEST(BadInputFiles, RandomBrokenMeshesNeverLoseTheScene) {
  uint64_t state = 0x9E3779B97F4A7C15ull;
  auto next = [&](int n) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<int>((state >> 33) % static_cast<uint64_t>(n));
  };
  const char* specials[] = {"nan", "inf", "-inf", "1e30", "0"};
  std::string text = "#usda 1.0\n";
  for (int m = 0; m < 40; ++m) {
    const int points = next(12), faces = 1 + next(8);
    std::string counts, indices, pts, normals;
    int corners = 0;
    for (int f = 0; f < faces; ++f) {
      const int c = next(6) - (next(10) == 0 ? 3 : 0);  // sometimes negative
      counts += std::to_string(c) + ", ";
      corners += std::max(c, 0);
    }
    corners += next(5) == 0 ? next(3) - 1 : 0;  // sometimes inconsistent
    for (int c = 0; c < corners; ++c)
      indices += std::to_string(next(10) == 0 ? next(points + 3) - 1 : next(std::max(points, 1))) + ", ";
    for (int p = 0; p < points; ++p) {
      auto coord = [&] { return next(15) == 0 ? std::string(specials[next(5)]) : std::to_string(next(7) - 3); };
      pts += std::string("(") + coord() + ", " + coord() + ", " + coord() + "), ";
    }
    for (int n = 0; n < next(points + 2); ++n) normals += "(0, " + std::string(next(4) == 0 ? "nan" : "1") + ", 0), ";
    const std::string scheme = next(3) == 0 ? "catmullClark" : "none";
    text += mesh(std::string("M") + std::to_string(m), counts, indices, pts,
                 normals.empty() ? "" : "    normal3f[] normals = [" + normals + "]\n", scheme);
  }
  const Scene s = read_usd_scene(write_file("random.usda", text), IngestOptions{});
  const TriangleSoup& t = s.triangles;
  for (const uint32_t i : t.indices) ASSERT_LT(i, t.positions.size());
  for (const V3f& p : t.positions) ASSERT_TRUE(std::isfinite(p.x + p.y + p.z));
  for (const V3f& n : t.normals) ASSERT_TRUE(std::isfinite(n.x + n.y + n.z));
  for (size_t i = 0; i < t.triangle_count(); ++i) {
    const V3f a = t.positions[t.indices[3 * i]], b = t.positions[t.indices[3 * i + 1]],
              c = t.positions[t.indices[3 * i + 2]];
    ASSERT_GT((b - a).cross(c - a).length(), 0.f) << t.mesh_paths[t.mesh[i]];
  }
  std::cout << "random meshes: " << t.triangle_count() << " triangles kept, " << s.warnings.size() << " warnings\n";
  EXPECT_GT(t.triangle_count(), 0u);  // the sound faces are kept
}

// Broken composition arcs: the prims read what composed, and each missing
// file is named with the prim that introduced it.
TEST(BadInputFiles, MissingReferencesPayloadsAndSublayersAreWarnings) {
  const fs::path path = write_file("arcs.usda", R"(#usda 1.0
(
    subLayers = [@missing_sub.usda@]
)
def Xform "Ref" (
    prepend references = @missing_ref.usda@
)
{
}
def Xform "Pay" (
    prepend payload = @missing_payload.usda@</Asset>
)
{
}
def Xform "Internal" (
    prepend references = </DoesNotExist>
)
{
}
def Mesh "Kept"
{
    uniform token subdivisionScheme = "none"
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
}
)");
  const Scene s = read_usd_scene(path, IngestOptions{});
  EXPECT_EQ(s.triangles.triangle_count(), 1u);
  const auto has = [&](const std::string& start, const std::string& text) {
    return std::any_of(s.warnings.begin(), s.warnings.end(), [&](const std::string& w) {
      return w.rfind(start, 0) == 0 && w.find(text) != std::string::npos;
    });
  };
  EXPECT_TRUE(has("/Ref: ", "missing_ref.usda")) << ::testing::PrintToString(s.warnings);
  EXPECT_TRUE(has("/Pay: ", "missing_payload.usda")) << ::testing::PrintToString(s.warnings);
  EXPECT_TRUE(has("/Internal: ", "DoesNotExist")) << ::testing::PrintToString(s.warnings);
  EXPECT_TRUE(has("", "missing_sub.usda")) << ::testing::PrintToString(s.warnings);
}

void expect_scene_error_naming(const fs::path& path) {
  try {
    read_usd_scene(path, IngestOptions{});
    FAIL() << "read " << path;
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
  }
}

TEST(BadInputFiles, UnreadableRootLayersAreSceneErrors) {
  expect_scene_error_naming(temp_dir());  // a directory
  expect_scene_error_naming(write_file("garbage.usdc", std::string("PXR-USDC\0\0\0garbage", 19)));
  expect_scene_error_naming(write_file("empty.usdz", ""));
  expect_scene_error_naming(write_file("binary.usda", std::string("\x89PNG\r\n\x1a\n\0\0", 10)));
}

TEST(BadInputFiles, MissingTextureKeepsTheMaterialConstant) {
  const fs::path path = write_file("tex.usda", R"(#usda 1.0
def Mesh "M" (
    prepend apiSchemas = ["MaterialBindingAPI"]
)
{
    uniform token subdivisionScheme = "none"
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    texCoord2f[] primvars:st = [(0, 0), (1, 0)] (
        interpolation = "vertex"
    )
    rel material:binding = </Mat>
}
def Material "Mat"
{
    token outputs:surface.connect = </Mat/S.outputs:surface>
    def Shader "S"
    {
        uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor.connect = </Mat/T.outputs:rgb>
        token outputs:surface
    }
    def Shader "R"
    {
        uniform token info:id = "UsdPrimvarReader_float2"
        string inputs:varname = "st"
        float2 outputs:result
    }
    def Shader "T"
    {
        uniform token info:id = "UsdUVTexture"
        asset inputs:file = @no_such_texture.png@
        float2 inputs:st.connect = </Mat/R.outputs:result>
        float3 outputs:rgb
    }
}
)");
  const Scene s = read_usd_scene(path, IngestOptions{});
  ASSERT_EQ(s.triangles.triangle_count(), 1u);
  EXPECT_FALSE(s.materials.at(s.triangles.material[0]).albedo_texture.bound());
  EXPECT_FALSE(s.warnings.empty());
}

}  // namespace
}  // namespace pbgi
