// The reader process on small scenes written to a temp dir: what it models,
// what it reports (once, naming the prim), and how it fails.
#include "server/ingest/usd_ingest.h"

#include "common/errors.h"

#include <gtest/gtest.h>

#include "tests/server/ingest/scratch_files.h"
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

using test::temp_dir;
using test::write_file;

// One scene exercising most of the reader: read once for the suite.
const char* kMixedScene = R"(#usda 1.0
(
    upAxis = "Z"
    metersPerUnit = 0.01
)
def Xform "W"
{
    def BasisCurves "Hair"
    {
        int[] curveVertexCounts = [2]
        point3f[] points = [(0, 0, 0), (1, 1, 1)]
    }
    def Mesh "Cage"
    {
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    }
    def Mesh "Right"
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
        color3f[] primvars:displayColor = [(0.2, 0.4, 0.6)]
    }
    def Mesh "Left"
    {
        uniform token subdivisionScheme = "none"
        uniform token orientation = "leftHanded"
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(0, 0, 2), (1, 0, 2), (1, 1, 2), (0, 1, 2)]
    }
    def Mesh "Hidden"
    {
        token visibility = "invisible"
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    }
    def Xform "Guides" (
    )
    {
        uniform token purpose = "guide"
        def Mesh "Guide"
        {
            uniform token subdivisionScheme = "none"
            int[] faceVertexCounts = [3]
            int[] faceVertexIndices = [0, 1, 2]
            point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
        }
    }
    def Mesh "Broken"
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 9]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    }
    def Sphere "Ball"
    {
        double radius = 0.5
        double3 xformOp:translate = (5, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Mesh "Textured" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 3), (1, 0, 3), (0, 1, 3)]
        rel material:binding = </W/Looks/Wood>
    }
    def Mesh "Split" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [4, 4]
        int[] faceVertexIndices = [0, 1, 4, 3, 1, 2, 5, 4]
        point3f[] points = [(0, 0, 4), (1, 0, 4), (2, 0, 4), (0, 1, 4), (1, 1, 4), (2, 1, 4)]
        rel material:binding = </W/Looks/Wood>
        uniform token subsetFamily:materialBind:familyType = "nonOverlapping"
        def GeomSubset "RightHalf" (
            prepend apiSchemas = ["MaterialBindingAPI"]
        )
        {
            uniform token elementType = "face"
            uniform token familyName = "materialBind"
            int[] indices = [1]
            rel material:binding = </W/Looks/Red>
        }
    }
    def Scope "Looks"
    {
        def Material "Red"
        {
            token outputs:surface.connect = </W/Looks/Red/Surface.outputs:surface>
            def Shader "Surface"
            {
                uniform token info:id = "UsdPreviewSurface"
                color3f inputs:diffuseColor = (0.8, 0.1, 0.1)
                token outputs:surface
            }
        }
        def Material "Wood"
        {
            token outputs:surface.connect = </W/Looks/Wood/Surface.outputs:surface>
            def Shader "Surface"
            {
                uniform token info:id = "UsdPreviewSurface"
                color3f inputs:diffuseColor.connect = </W/Looks/Wood/Tex.outputs:rgb>
                color3f inputs:emissiveColor = (0, 0, 0)
                token outputs:surface
            }
            def Shader "Tex"
            {
                uniform token info:id = "UsdUVTexture"
                asset inputs:file = @wood.png@
                float3 outputs:rgb
            }
        }
    }
    def DomeLight "Sky"
    {
    }
    def RectLight "Panel"
    {
        float inputs:width = 2
        float inputs:height = 0.5
        float inputs:intensity = 10
        float inputs:exposure = 1
        bool inputs:normalize = 1
    }
}
class Xform "Proto"
{
    def Mesh "Tri"
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    }
}
def Xform "Inst1" (
    instanceable = true
    prepend references = </Proto>
)
{
    double3 xformOp:translate = (0, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Xform "Inst2" (
    instanceable = true
    prepend references = </Proto>
)
{
    double3 xformOp:translate = (0, 0, 20)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
)";

class UsdReader : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scene_ = new Scene(read_usd_scene(write_file("mixed.usda", kMixedScene), IngestOptions{}));
  }
  static void TearDownTestSuite() {
    delete scene_;
    scene_ = nullptr;
  }
  static const Scene& scene() { return *scene_; }

  static std::vector<size_t> triangles_of(const Scene& s, const std::string& prim) {
    std::vector<size_t> out;
    for (size_t t = 0; t < s.triangles.triangle_count(); ++t)
      if (s.triangles.mesh_paths[s.triangles.mesh[t]] == prim) out.push_back(t);
    return out;
  }
  static V3f geometric_normal(const Scene& s, size_t t) {
    const auto& p = s.triangles.positions;
    const auto& i = s.triangles.indices;
    return (p[i[3 * t + 1]] - p[i[3 * t]]).cross(p[i[3 * t + 2]] - p[i[3 * t]]).normalized();
  }
  static size_t warnings_naming(const std::string& prim, const std::string& text = "") {
    return std::count_if(scene().warnings.begin(), scene().warnings.end(), [&](const std::string& w) {
      return w.rfind(prim + ": ", 0) == 0 && w.find(text) != std::string::npos;
    });
  }

  static Scene* scene_;
};
Scene* UsdReader::scene_ = nullptr;

TEST_F(UsdReader, RecordsUpAxisWithoutRotatingGeometry) {
  EXPECT_EQ(scene().up_axis, "Z");
  EXPECT_DOUBLE_EQ(scene().meters_per_unit, 0.01);
  // /W/Right lies in z = 1 exactly as authored.
  for (size_t t : triangles_of(scene(), "/W/Right"))
    for (int k = 0; k < 3; ++k)
      EXPECT_FLOAT_EQ(scene().triangles.positions[scene().triangles.indices[3 * t + k]].z, 1.f);
}

TEST_F(UsdReader, UnsupportedPrimsAreReportedOnceByPath) {
  EXPECT_EQ(warnings_naming("/W/Hair", "BasisCurves"), 1u);
  // DomeLights are modelled (looks_ingest_test.cpp): a constant dome, no warning.
  EXPECT_EQ(warnings_naming("/W/Sky"), 0u);
  EXPECT_TRUE(triangles_of(scene(), "/W/Hair").empty());
}

TEST_F(UsdReader, CatmullClarkMeshIsRefined) {
  // No subdivisionScheme authored: USD's default is catmullClark, refined
  // to the default level 2 (subdiv_ingest_test.cpp covers the details).
  EXPECT_EQ(triangles_of(scene(), "/W/Cage").size(), 2u * 16);
  EXPECT_EQ(warnings_naming("/W/Cage", "subdivision"), 0u);
}

TEST_F(UsdReader, OrientationDecidesTheWinding) {
  // Same counter-clockwise-from-+z quad: rightHanded faces +z, leftHanded -z.
  for (size_t t : triangles_of(scene(), "/W/Right")) EXPECT_NEAR(geometric_normal(scene(), t).z, 1.f, 1e-6f);
  const auto left = triangles_of(scene(), "/W/Left");
  ASSERT_EQ(left.size(), 2u);
  for (size_t t : left) EXPECT_NEAR(geometric_normal(scene(), t).z, -1.f, 1e-6f);
}

TEST_F(UsdReader, InvisibleAndGuidePrimsAreSkipped) {
  EXPECT_TRUE(triangles_of(scene(), "/W/Hidden").empty());
  EXPECT_TRUE(triangles_of(scene(), "/W/Guides/Guide").empty());
}

TEST_F(UsdReader, NativeInstancesShareOnePrototypePlacedInPlace) {
  // One prototype (read through the first instance's proxies, so its mesh
  // is named by that path), two placements; nothing in the world soup.
  ASSERT_EQ(scene().prototypes.size(), 1u);
  ASSERT_EQ(scene().prototypes[0].triangles.triangle_count(), 1u);
  EXPECT_EQ(scene().prototypes[0].triangles.mesh_paths[0], "/Inst1/Tri");
  ASSERT_EQ(scene().instances.size(), 2u);
  std::vector<float> z;
  for (const Instance& i : scene().instances) {
    TriangleRef r{&scene().prototypes[i.prototype].triangles, 0, &i};
    z.push_back(r.position(0).z);
  }
  std::sort(z.begin(), z.end());
  EXPECT_FLOAT_EQ(z[0], 10.f);
  EXPECT_FLOAT_EQ(z[1], 20.f);
  EXPECT_TRUE(triangles_of(scene(), "/Inst1/Tri").empty());  // world soup
  EXPECT_TRUE(triangles_of(scene(), "/Proto/Tri").empty());  // class prims are abstract
}

TEST_F(UsdReader, BadMeshIsSkippedWithAnErrorNamingIt) {
  EXPECT_TRUE(triangles_of(scene(), "/W/Broken").empty());
  EXPECT_EQ(warnings_naming("/W/Broken", "faceVertexIndices"), 1u);
}

TEST_F(UsdReader, ImplicitSphereIsTessellatedFacingOut) {
  const auto tris = triangles_of(scene(), "/W/Ball");
  ASSERT_GT(tris.size(), 500u);
  const V3f center(5.f, 0.f, 0.f);
  float area = 0.f;
  for (size_t t : tris) {
    const auto& p = scene().triangles.positions;
    const auto& i = scene().triangles.indices;
    const V3f a = p[i[3 * t]], b = p[i[3 * t + 1]], c = p[i[3 * t + 2]];
    EXPECT_GT(geometric_normal(scene(), t).dot((a + b + c) / 3.f - center), 0.f);
    EXPECT_NEAR((a - center).length(), 0.5f, 1e-5f);
    area += 0.5f * (b - a).cross(c - a).length();
  }
  EXPECT_NEAR(area, 4.f * float(M_PI) * 0.25f, 0.01f);
}

TEST_F(UsdReader, MaterialsComeFromBindingDisplayColorOrTextureFallback) {
  const auto albedo = [&](const std::string& prim) {
    return scene().materials[scene().triangles.material[triangles_of(scene(), prim).at(0)]].albedo;
  };
  EXPECT_NEAR(albedo("/W/Right").x, 0.2f, 1e-6f);
  EXPECT_NEAR(albedo("/W/Right").y, 0.4f, 1e-6f);
  EXPECT_NEAR(albedo("/W/Right").z, 0.6f, 1e-6f);
  // A textured diffuseColor is not modelled: grey plus one warning naming the material.
  EXPECT_EQ(albedo("/W/Textured"), C3f(0.5f, 0.5f, 0.5f));
  EXPECT_EQ(warnings_naming("/W/Looks/Wood", "texture"), 1u);
}

TEST_F(UsdReader, GeomSubsetsBindMaterialsPerFace) {
  const auto tris = triangles_of(scene(), "/W/Split");
  ASSERT_EQ(tris.size(), 4u);
  for (size_t t : tris) {
    const auto& p = scene().triangles.positions;
    const auto& i = scene().triangles.indices;
    const float cx = (p[i[3 * t]].x + p[i[3 * t + 1]].x + p[i[3 * t + 2]].x) / 3.f;
    const Material& m = scene().materials[scene().triangles.material[t]];
    // Face 1 (x in [1, 2]) is in the subset bound to Red; face 0 keeps Wood.
    EXPECT_EQ(m.prim_path, cx > 1.f ? "/W/Looks/Red" : "/W/Looks/Wood") << cx;
  }
}

TEST_F(UsdReader, NormalizedRectLightRadianceIsPowerOverArea) {
  ASSERT_EQ(scene().lights.size(), 2u);  // and the constant dome /W/Sky
  EXPECT_EQ(scene().lights[0].prim_path, "/W/Sky");
  EXPECT_EQ(scene().lights[0].kind, LightKind::Dome);
  const Light& l = scene().lights[1];
  EXPECT_EQ(l.prim_path, "/W/Panel");
  // intensity 10 * 2^1 exposure / (2 x 0.5) area.
  EXPECT_NEAR(l.radiance.x, 20.f, 1e-5f);
  EXPECT_FLOAT_EQ(l.width, 2.f);
  EXPECT_FLOAT_EQ(l.height, 0.5f);
}

TEST(UsdReaderFiles, MissingFileIsASceneErrorNamingThePath) {
  const fs::path missing = temp_dir() / "does_not_exist.usda";
  try {
    read_usd_scene(missing, IngestOptions{});
    FAIL() << "read a missing file";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find(missing.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no such file"), std::string::npos) << e.what();
  }
}

TEST(UsdReaderFiles, UnparseableUsdaIsASceneErrorNamingThePath) {
  const fs::path bad = write_file("bad.usda", "#usda 1.0\ndef Mesh \"X\" { this is not usda\n");
  try {
    read_usd_scene(bad, IngestOptions{});
    FAIL() << "read a broken file";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find(bad.string()), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find("Traceback"), std::string::npos) << e.what();
  }
}

TEST(UsdReaderFiles, LargeMeshesAreChunkedWithoutLosingTriangles) {
  // A 20 x 20 grid of quads (800 triangles) in chunks of at most 64, under
  // a mirroring transform (which flips the winding relative to the normal).
  std::string counts, indices, points;
  const int n = 20;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) points += "(" + std::to_string(x) + ", " + std::to_string(y) + ", 0), ";
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const int v = y * (n + 1) + x;
      counts += "4, ";
      indices += std::to_string(v) + ", " + std::to_string(v + 1) + ", " + std::to_string(v + n + 2) + ", " +
                 std::to_string(v + n + 1) + ", ";
    }
  const fs::path path = write_file("grid.usda", "#usda 1.0\ndef Mesh \"Grid\"\n{\n"
                                                "    uniform token subdivisionScheme = \"none\"\n"
                                                "    int[] faceVertexCounts = [" + counts + "]\n"
                                                "    int[] faceVertexIndices = [" + indices + "]\n"
                                                "    point3f[] points = [" + points + "]\n"
                                                "    double3 xformOp:scale = (-1, 1, 1)\n"
                                                "    uniform token[] xformOpOrder = [\"xformOp:scale\"]\n}\n");
  IngestOptions options;
  options.max_triangles_per_chunk = 64;
  const Scene s = read_usd_scene(path, options);
  ASSERT_EQ(s.triangles.triangle_count(), 800u);
  EXPECT_EQ(s.triangles.mesh_paths, std::vector<std::string>{"/Grid"});
  float area = 0.f;
  for (size_t t = 0; t < s.triangles.triangle_count(); ++t) {
    const auto& p = s.triangles.positions;
    const auto& i = s.triangles.indices;
    const V3f g = (p[i[3 * t + 1]] - p[i[3 * t]]).cross(p[i[3 * t + 2]] - p[i[3 * t]]);
    // Mirrored in x, the surface still faces +z: the reader flipped the winding.
    EXPECT_GT(g.z, 0.f);
    area += 0.5f * g.length();
  }
  EXPECT_NEAR(area, float(n * n), 1e-3f);
}

TEST(UsdReaderFiles, TimeCodeSelectsTheSample) {
  const fs::path path = write_file("animated.usda", R"(#usda 1.0
(
    startTimeCode = 1
    endTimeCode = 10
)
def Mesh "Tri"
{
    uniform token subdivisionScheme = "none"
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points.timeSamples = {
        1: [(0, 0, 0), (1, 0, 0), (0, 1, 0)],
        10: [(0, 0, 9), (1, 0, 9), (0, 1, 9)],
    }
}
)");
  // Default: the stage's startTimeCode.
  const Scene first = read_usd_scene(path, IngestOptions{});
  ASSERT_EQ(first.triangles.triangle_count(), 1u);
  EXPECT_FLOAT_EQ(first.triangles.positions[0].z, 0.f);
  IngestOptions at10;
  at10.time_code = 10.0;
  const Scene last = read_usd_scene(path, at10);
  ASSERT_EQ(last.triangles.triangle_count(), 1u);
  EXPECT_FLOAT_EQ(last.triangles.positions[0].z, 9.f);
  EXPECT_NE(first.content_hash, last.content_hash);
}

TEST(UsdReaderFiles, ReaderFailureCarriesItsExitStatusAndStderr) {
  IngestOptions options;
  options.reader_script = write_file("failing_reader.py",
                                     "import sys\n"
                                     "sys.stderr.write('reader says boom\\n')\n"
                                     "sys.exit(3)\n");
  try {
    read_usd_scene(write_file("any.usda", "#usda 1.0\n"), options);
    FAIL() << "a failing reader produced a scene";
  } catch (const SceneError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("any.usda"), std::string::npos) << what;
    EXPECT_NE(what.find("status 3"), std::string::npos) << what;
    EXPECT_NE(what.find("reader says boom"), std::string::npos) << what;
  }
}

TEST(UsdReaderFiles, GarbageFromTheReaderIsRejectedAndTheReaderStopped) {
  // A reader that writes garbage forever: the stream is rejected at frame 0
  // and the reader must not be left running (it would block this test).
  IngestOptions options;
  options.reader_script = write_file("garbage_reader.py",
                                     "import sys\n"
                                     "while True:\n"
                                     "    sys.stdout.buffer.write(b'garbage ' * 1024)\n");
  const auto start = std::chrono::steady_clock::now();
  try {
    read_usd_scene(write_file("any.usda", "#usda 1.0\n"), options);
    FAIL() << "garbage produced a scene";
  } catch (const SceneError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("any.usda"), std::string::npos) << what;
    EXPECT_NE(what.find("frame 0"), std::string::npos) << what;
  }
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10));
}

TEST(UsdReaderFiles, MissingInterpreterIsAnIoError) {
  IngestOptions options;
  options.python = "/nonexistent/python3";
  EXPECT_THROW(read_usd_scene(write_file("mixed.usda", kMixedScene), options), IoError);
}

}  // namespace
}  // namespace pbgi
