// Draco meshes (round trips within the documented error bound, .drc files
// as scenes) and the chunk store of ingested scenes.
#include "server/ingest/chunk_store.h"
#include "server/ingest/draco_mesh.h"
#include "server/ingest/usd_ingest.h"

#include "common/errors.h"
#include "pbgi/v1/scene.pb.h"
#include "tests/server/ingest/scene_frames.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cmath>
#include <fstream>
#include <iostream>
#include <iterator>
#include <limits>
#include <optional>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

fs::path temp_dir() {
  static const struct Dir {
    fs::path path = fs::temp_directory_path() / ("pbgi_chunk_store_test_" + std::to_string(getpid()));
    Dir() { fs::create_directories(path); }
    ~Dir() {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  } dir;
  return dir.path;
}

// A wavy n x n grid spanning x in [-3, 7], with normals and uvs.
DracoMesh wavy_grid(int n) {
  DracoMesh m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const float u = float(i) / n, v = float(j) / n;
      const float x = -3.f + 10.f * u, y = 2.f * v, z = 0.3f * std::sin(7.f * u) * std::cos(5.f * v);
      m.positions.emplace_back(x, y, z);
      // Normal of z = f(x, y): (-df/dx, -df/dy, 1), normalized.
      const V3f n3(-0.3f * 7.f / 10.f * std::cos(7.f * u) * std::cos(5.f * v),
                   0.3f * 5.f / 2.f * std::sin(7.f * u) * std::sin(5.f * v), 1.f);
      m.normals.push_back(n3.normalized());
      m.uvs.emplace_back(u, v);
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
    }
  return m;
}

float range_of(const std::vector<V3f>& p) {
  Box3f box;
  for (const V3f& v : p) box.extendBy(v);
  const V3f s = box.size();
  return std::max({s.x, s.y, s.z});
}

TEST(Draco, RoundTripStaysWithinTheDocumentedBound) {
  const DracoMesh in = wavy_grid(40);
  const float range = range_of(in.positions);
  for (const int bits : {8, 11, 14, 16}) {
    DracoOptions options;
    options.position_bits = bits;
    options.normal_bits = 10;
    const std::string bytes = encode_draco_mesh(in, options);
    const DracoMesh out = decode_draco_mesh(bytes, "round trip");
    ASSERT_EQ(out.positions.size(), in.positions.size()) << bits;
    ASSERT_EQ(out.indices, in.indices) << "sequential encoding keeps the order";
    const double bound = draco_position_error_bound(range, bits);
    double worst = 0.0;
    for (size_t i = 0; i < in.positions.size(); ++i)
      for (int k = 0; k < 3; ++k) worst = std::max(worst, double(std::abs(out.positions[i][k] - in.positions[i][k])));
    EXPECT_LE(worst, bound) << bits << " bits";
    // The bound is tight-ish: the error is not orders of magnitude below it.
    EXPECT_GT(worst, bound * 0.05) << bits << " bits";
    float worst_angle = 0.f;
    for (size_t i = 0; i < in.normals.size(); ++i)
      worst_angle = std::max(worst_angle, std::acos(std::min(1.f, out.normals[i].normalized().dot(in.normals[i]))));
    EXPECT_LT(worst_angle, float(M_PI) / (1 << (options.normal_bits - 1))) << bits;
    ASSERT_EQ(out.uvs.size(), in.uvs.size());
    if (bits == 16) {
      std::cout << "draco: " << in.positions.size() << " vertices, " << in.indices.size() / 3 << " triangles: "
                << bytes.size() << " bytes at " << bits << " bits (raw "
                << in.positions.size() * 32 + in.indices.size() * 4 << "), max error " << worst << " <= " << bound
                << "\n";
    }
  }
}

TEST(Draco, DrcFileGivenDirectlyIsDecodedIntoTriangles) {
  const DracoMesh in = wavy_grid(12);
  DracoOptions options;
  options.preserve_order = false;  // edgebreaker, as .drc files usually are
  options.position_bits = 14;
  const fs::path path = temp_dir() / "wavy.drc";
  std::ofstream(path, std::ios::binary) << encode_draco_mesh(in, options);

  const Scene s = read_usd_scene(path, IngestOptions{});
  ASSERT_EQ(s.triangles.triangle_count(), in.indices.size() / 3);
  EXPECT_EQ(s.triangles.mesh_paths, std::vector<std::string>{"/wavy"});
  EXPECT_EQ(s.triangles.normals.size(), s.triangles.positions.size());
  // Edgebreaker reorders vertices: each decoded one is near an original one.
  const double bound = draco_position_error_bound(range_of(in.positions), 14);
  for (const V3f& p : s.triangles.positions) {
    double best = 1e9;
    for (const V3f& q : in.positions)
      best = std::min(best, double(std::max({std::abs(p.x - q.x), std::abs(p.y - q.y), std::abs(p.z - q.z)})));
    EXPECT_LE(best, bound);
  }

  const fs::path garbage = temp_dir() / "garbage.drc";
  std::ofstream(garbage) << "DRACO but not really";
  EXPECT_THROW(read_usd_scene(garbage, IngestOptions{}), SceneError);
  EXPECT_THROW(read_usd_scene(temp_dir() / "missing.drc", IngestOptions{}), SceneError);
}

// A .drc that a prim references (as the USD Draco plugin allows): decoded
// in the daemon, placed by the prim's transform, mirrored winding fixed.
TEST(Draco, DrcReferencedFromUsdIsPlacedByThePrim) {
  const DracoMesh in = wavy_grid(10);
  DracoOptions options;
  options.preserve_order = false;
  const fs::path dir = temp_dir() / "drcref";
  fs::create_directories(dir);
  std::ofstream(dir / "wavy.drc", std::ios::binary) << encode_draco_mesh(in, options);
  std::ofstream(dir / "scene.usda") << R"(#usda 1.0
def Mesh "Wavy" (
    prepend references = @wavy.drc@
)
{
    double3 xformOp:translate = (0, 5, 0)
    double3 xformOp:scale = (-1, 1, 1)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
}
def Xform "Missing" (
    prepend payload = @missing.drc@
)
{
}
)";
  const Scene s = read_usd_scene(dir / "scene.usda", IngestOptions{});
  ASSERT_EQ(s.triangles.triangle_count(), in.indices.size() / 3);
  EXPECT_EQ(s.triangles.mesh_paths, std::vector<std::string>{"/Wavy"});
  Box3f box;
  for (const V3f& p : s.triangles.positions) box.extendBy(p);
  EXPECT_NEAR(box.min.x, -7.f, 1e-3f);  // x in [-3, 7] mirrored
  EXPECT_NEAR(box.max.x, 3.f, 1e-3f);
  EXPECT_NEAR(box.min.y, 5.f, 1e-3f);
  ASSERT_EQ(s.triangles.normals.size(), s.triangles.positions.size());
  for (size_t t = 0; t < s.triangles.triangle_count(); ++t) {
    const auto& p = s.triangles.positions;
    const auto& i = s.triangles.indices;
    const V3f g = (p[i[3 * t + 1]] - p[i[3 * t]]).cross(p[i[3 * t + 2]] - p[i[3 * t]]);
    EXPECT_GT(g.dot(s.triangles.normals[i[3 * t]]), 0.f) << t;
  }
  // The unreadable one is a warning naming the prim and the file.
  EXPECT_TRUE(std::any_of(s.warnings.begin(), s.warnings.end(), [](const std::string& w) {
    return w.rfind("/Missing: ", 0) == 0 && w.find("missing.drc") != std::string::npos;
  })) << ::testing::PrintToString(s.warnings);
}

const char* kStoredScene = R"(#usda 1.0
def Mesh "Cage" (
    prepend apiSchemas = ["MaterialBindingAPI"]
)
{
    rel material:binding = </Looks/Shiny>
    int[] faceVertexCounts = [4, 4, 4, 4, 4, 4]
    int[] faceVertexIndices = [0, 1, 3, 2, 2, 3, 5, 4, 4, 5, 7, 6, 6, 7, 1, 0, 1, 7, 5, 3, 6, 0, 2, 4]
    point3f[] points = [(-1, -1, 1), (1, -1, 1), (-1, 1, 1), (1, 1, 1), (-1, 1, -1), (1, 1, -1), (-1, -1, -1), (1, -1, -1)]
}
def Mesh "Floor"
{
    uniform token subdivisionScheme = "none"
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    point3f[] points = [(-5, -2, -5), (-5, -2, 5), (5, -2, 5), (5, -2, -5)]
    color3f[] primvars:displayColor = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1)] (
        interpolation = "vertex"
    )
}
def Scope "Looks"
{
    def Material "Shiny"
    {
        token outputs:surface.connect = </Looks/Shiny/S.outputs:surface>
        def Shader "S"
        {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (0.2, 0.3, 0.4)
            color3f inputs:emissiveColor = (1, 2, 3)
            float inputs:roughness = 0.25
            int inputs:useSpecularWorkflow = 1
            color3f inputs:specularColor = (0.5, 0.25, 0.125)
            float inputs:ior = 1.33
            float inputs:opacity = 0.75
            float inputs:opacityThreshold = 0.5
            token outputs:surface
        }
    }
}
def RectLight "Key"
{
    float inputs:intensity = 5
    float inputs:width = 2
}
def Camera "Cam"
{
    float horizontalApertureOffset = 1.5
    double3 xformOp:translate = (0, 0, 9)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def BasisCurves "Hair"
{
    int[] curveVertexCounts = [2]
    point3f[] points = [(0, 0, 0), (1, 1, 1)]
}
)";

TEST(ChunkStore, ReopeningAnUnchangedSceneSkipsIngest) {
  const fs::path scene_path = temp_dir() / "stored.usda";
  std::ofstream(scene_path) << kStoredScene;
  ChunkStoreOptions store_options;
  store_options.directory = temp_dir() / "store";
  store_options.max_triangles_per_chunk = 100;  // several chunks per mesh
  const ChunkStore store(store_options);
  IngestOptions options;
  options.target_edge_length = 0.05f;  // refined cage: ~6 levels deep

  using Clock = std::chrono::steady_clock;
  bool from_store = true;
  const auto t0 = Clock::now();
  const Scene first = read_usd_scene_cached(scene_path, options, store, {}, &from_store);
  const auto t1 = Clock::now();
  EXPECT_FALSE(from_store);
  const Scene second = read_usd_scene_cached(scene_path, options, store, {}, &from_store);
  const auto t2 = Clock::now();
  EXPECT_TRUE(from_store);
  std::cout << "chunk store: ingest " << std::chrono::duration<double>(t1 - t0).count() << " s, reopen "
            << std::chrono::duration<double>(t2 - t1).count() << " s, " << first.triangles.triangle_count()
            << " triangles, entry " << fs::file_size(store.entry_path(store.key(usd_content_hash(scene_path, options), options)))
            << " bytes\n";

  // Same model: triangles in order, within the bound of their chunk.
  ASSERT_EQ(second.triangles.triangle_count(), first.triangles.triangle_count());
  EXPECT_EQ(second.content_hash, first.content_hash);
  EXPECT_EQ(second.warnings, first.warnings);
  const double bound = draco_position_error_bound(range_of(first.triangles.positions), store_options.draco.position_bits);
  for (size_t t = 0; t < first.triangles.triangle_count(); ++t) {
    ASSERT_EQ(second.triangles.mesh_paths[second.triangles.mesh[t]], first.triangles.mesh_paths[first.triangles.mesh[t]]);
    ASSERT_EQ(second.triangles.material[t], first.triangles.material[t]);
    for (int k = 0; k < 3; ++k) {
      const V3f a = first.triangles.positions[first.triangles.indices[3 * t + k]];
      const V3f b = second.triangles.positions[second.triangles.indices[3 * t + k]];
      ASSERT_LE((a - b).length(), std::sqrt(3.0) * bound) << t;
    }
  }
  // The floor's vertex colours survive (the refined cage has none: NaN).
  ASSERT_EQ(first.triangles.colors.size(), first.triangles.positions.size());
  ASSERT_EQ(second.triangles.colors.size(), second.triangles.positions.size());
  for (size_t t = 0; t < first.triangles.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k) {
      const C3f a = first.triangles.colors[first.triangles.indices[3 * t + k]];
      const C3f b = second.triangles.colors[second.triangles.indices[3 * t + k]];
      if (std::isnan(a.x)) {
        ASSERT_TRUE(std::isnan(b.x));
      } else {
        ASSERT_NEAR(a.x, b.x, 1e-3f);
        ASSERT_NEAR(a.z, b.z, 1e-3f);
      }
    }
  ASSERT_EQ(second.materials.size(), first.materials.size());
  for (size_t m = 0; m < first.materials.size(); ++m) {
    EXPECT_EQ(second.materials[m].prim_path, first.materials[m].prim_path);
    EXPECT_EQ(second.materials[m].albedo, first.materials[m].albedo);
    EXPECT_EQ(second.materials[m].emission, first.materials[m].emission);
    EXPECT_EQ(second.materials[m].roughness, first.materials[m].roughness);
    EXPECT_EQ(second.materials[m].metallic, first.materials[m].metallic);
    EXPECT_EQ(second.materials[m].specular_color, first.materials[m].specular_color);
    EXPECT_EQ(second.materials[m].use_specular_workflow, first.materials[m].use_specular_workflow);
    EXPECT_EQ(second.materials[m].ior, first.materials[m].ior);
    EXPECT_EQ(second.materials[m].albedo_from_vertex_colors, first.materials[m].albedo_from_vertex_colors);
    EXPECT_EQ(second.materials[m].opacity, first.materials[m].opacity);
    EXPECT_EQ(second.materials[m].opacity_threshold, first.materials[m].opacity_threshold);
    if (first.materials[m].prim_path == "/Looks/Shiny") {
      EXPECT_EQ(first.materials[m].opacity, 0.75f);
      EXPECT_EQ(first.materials[m].opacity_threshold, 0.5f);
    }
  }
  ASSERT_EQ(second.lights.size(), 1u);
  EXPECT_EQ(second.lights[0].radiance, first.lights[0].radiance);
  EXPECT_EQ(second.lights[0].local_to_world, first.lights[0].local_to_world);
  ASSERT_NE(second.find_camera("/Cam"), nullptr);
  EXPECT_EQ(second.find_camera("/Cam")->horizontal_aperture_offset, 1.5f);

  // Different refinement options are a different entry.
  IngestOptions coarser = options;
  coarser.target_edge_length = 0.5f;
  read_usd_scene_cached(scene_path, coarser, store, {}, &from_store);
  EXPECT_FALSE(from_store);

  // An edited scene is a miss; a corrupt entry is dropped, not trusted.
  std::ofstream(scene_path, std::ios::app) << "def Sphere \"Ball\"\n{\n}\n";
  const Scene edited = read_usd_scene_cached(scene_path, options, store, {}, &from_store);
  EXPECT_FALSE(from_store);
  EXPECT_GT(edited.triangles.triangle_count(), first.triangles.triangle_count());
  const std::string key = store.key(usd_content_hash(scene_path, options), options);
  ASSERT_TRUE(store.contains(key));
  fs::resize_file(store.entry_path(key), fs::file_size(store.entry_path(key)) / 2);
  EXPECT_FALSE(store.load(key).has_value());
  EXPECT_FALSE(store.contains(key));
}

// Measurement hook: PBGI_MEASURE_SCENE=<scene> [PBGI_MEASURE_EDGE=<target
// edge length>] times ingest vs reopen from the store (skipped otherwise).
TEST(ChunkStore, MeasureIngestVersusReopen) {
  const char* scene = std::getenv("PBGI_MEASURE_SCENE");
  if (!scene) GTEST_SKIP() << "set PBGI_MEASURE_SCENE to measure";
  ChunkStoreOptions store_options;
  store_options.directory = temp_dir() / "measure";
  const ChunkStore store(store_options);
  IngestOptions options;
  if (const char* edge = std::getenv("PBGI_MEASURE_EDGE")) options.target_edge_length = std::stof(edge);
  using Clock = std::chrono::steady_clock;
  bool from_store = false;
  const auto t0 = Clock::now();
  const Scene first = read_usd_scene_cached(scene, options, store, {}, &from_store);
  const auto t1 = Clock::now();
  const Scene second = read_usd_scene_cached(scene, options, store, {}, &from_store);
  const auto t2 = Clock::now();
  EXPECT_TRUE(from_store);
  const std::string key = store.key(usd_content_hash(scene, options), options);
  const auto t3 = Clock::now();
  const size_t raw = first.triangles.positions.size() * (sizeof(V3f) * (first.triangles.normals.empty() ? 1 : 2)) +
                     first.triangles.indices.size() * 4;
  std::cout << scene << ": " << first.triangles.triangle_count() << " triangles; ingest+save "
            << std::chrono::duration<double>(t1 - t0).count() << " s, reopen "
            << std::chrono::duration<double>(t2 - t1).count() << " s (of which hashing "
            << std::chrono::duration<double>(t3 - t2).count() << " s); entry "
            << fs::file_size(store.entry_path(key)) << " bytes vs " << raw << " bytes raw positions+normals+indices\n";
}

TEST(Draco, CorruptDracoMeshChunkIsASceneErrorNamingTheMesh) {
  const fs::path path = temp_dir() / "corrupt.stream";
  {
    std::ofstream out(path, std::ios::binary);
    auto frame = [&](const pbgi::v1::SceneChunk& c) { out << test::framed(c); };
    pbgi::v1::SceneChunk c;
    c.mutable_header()->set_content_hash("h");
    c.mutable_header()->set_meters_per_unit(1.0);
    frame(c);
    c.Clear();
    c.mutable_material()->set_id(0);
    frame(c);
    c.Clear();
    c.mutable_mesh()->set_prim_path("/Broken");
    c.mutable_mesh()->set_draco("DRACO\x02\x02garbage");
    frame(c);
  }
  const int fd = ::open(path.c_str(), O_RDONLY);
  ASSERT_GE(fd, 0);
  try {
    decode_scene_stream(fd, path.string());
    FAIL() << "decoded a corrupt Draco chunk";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("/Broken"), std::string::npos) << e.what();
  }
  ::close(fd);
}

// Issue 17: positions spanning more than the float range made Draco's
// entropy coder read out of bounds (a segfault in ComputeShannonEntropy,
// taking the daemon down). The encoder refuses such values itself.
TEST(Draco, ValuesSpanningMoreThanTheFloatRangeAreRefusedNotACrash) {
  DracoMesh m;
  m.positions = {V3f(3e38f, 0, 0), V3f(-3e38f, 3e38f, 0), V3f(0, 0, -3e38f)};
  m.indices = {0, 1, 2};
  EXPECT_THROW(encode_draco_mesh(m, DracoOptions{}), InvalidArgument);
  m.positions = {V3f(0, 0, 0), V3f(1, 0, 0), V3f(0, std::numeric_limits<float>::infinity(), 0)};
  EXPECT_THROW(encode_draco_mesh(m, DracoOptions{}), InvalidArgument);
  m.positions = {V3f(0, 0, 0), V3f(1, 0, 0), V3f(0, 1, 0)};
  m.uvs = {V2f(3e38f, 0), V2f(-3e38f, 0), V2f(0, 0)};
  EXPECT_THROW(encode_draco_mesh(m, DracoOptions{}), InvalidArgument);
  m.uvs.clear();
  EXPECT_FALSE(encode_draco_mesh(m, DracoOptions{}).empty());
}

// The issue's scene, end to end: the huge triangle (as a plain mesh and as a
// subdivision cage) is skipped with a warning naming its prim; the scene
// opens, is stored and reopens from the store.
TEST(ChunkStore, CoordinatesBeyondTheFloatRangeAreSkippedNotACrash) {
  const fs::path dir = temp_dir() / "huge";
  fs::create_directories(dir);
  std::ofstream(dir / "huge.usda") << R"(#usda 1.0
def Mesh "Huge"
{
    uniform token subdivisionScheme = "none"
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(3e38, 0, 0), (-3e38, 3e38, 0), (0, 0, -3e38)]
}
def Mesh "HugeCage"
{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(3e38, 0, 0), (-3e38, 3e38, 0), (0, 0, -3e38)]
}
def Mesh "Floor"
{
    uniform token subdivisionScheme = "none"
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    point3f[] points = [(-5, 0, -5), (-5, 0, 5), (5, 0, 5), (5, 0, -5)]
}
)";
  ChunkStoreOptions store_options;
  store_options.directory = dir / "store";
  const ChunkStore store(store_options);
  bool from_store = true;
  const Scene first = read_usd_scene_cached(dir / "huge.usda", IngestOptions{}, store, {}, &from_store);
  EXPECT_FALSE(from_store);
  const Scene second = read_usd_scene_cached(dir / "huge.usda", IngestOptions{}, store, {}, &from_store);
  EXPECT_TRUE(from_store);
  for (const Scene* s : {&first, &second}) {
    const TriangleSoup& t = s->triangles;
    ASSERT_EQ(t.triangle_count(), 2u);
    for (size_t i = 0; i < t.triangle_count(); ++i) EXPECT_EQ(t.mesh_paths[t.mesh[i]], "/Floor");
    for (const char* prim : {"/Huge: ", "/HugeCage: "})
      EXPECT_TRUE(std::any_of(s->warnings.begin(), s->warnings.end(), [&](const std::string& w) {
        return w.rfind(prim, 0) == 0 && w.find("exceed") != std::string::npos;
      })) << prim << ::testing::PrintToString(s->warnings);
  }
  EXPECT_EQ(second.warnings, first.warnings);
}

// A small scene of every kind of chunk, made in memory (no reader).
Scene flips_scene() {
  Scene s;
  s.source_path = "/scenes/flips.usda";
  s.content_hash = "flips";
  s.meters_per_unit = 1.0;
  s.materials.resize(2);
  s.materials[0].prim_path = "/Looks/Red";
  s.materials[0].albedo = C3f(0.8f, 0.1f, 0.1f);
  s.materials[1].prim_path = "/Looks/Lamp";
  s.materials[1].emission = C3f(4.f, 4.f, 3.f);
  TriangleSoup& t = s.triangles;
  t.positions = {V3f(0, 0, 0), V3f(2, 0, 0), V3f(2, 2, 0), V3f(0, 2, 0), V3f(1, 1, 1), V3f(1.5f, 1, 1), V3f(1, 1.5f, 1)};
  t.normals.assign(t.positions.size(), V3f(0, 0, 1));
  t.uvs = {V2f(0, 0), V2f(1, 0), V2f(1, 1), V2f(0, 1), V2f(0, 0), V2f(1, 0), V2f(0, 1)};
  t.indices = {0, 1, 2, 0, 2, 3, 4, 5, 6};
  t.material = {0, 0, 1};
  t.mesh = {0, 0, 1};
  t.mesh_paths = {"/Floor", "/Lamp"};
  t.double_sided = {0, 1};
  s.prototypes.resize(1);
  s.prototypes[0].prim_path = "/Proto";
  TriangleSoup& p = s.prototypes[0].triangles;
  p.positions = {V3f(0, 0, 0), V3f(0.5f, 0, 0), V3f(0, 0.5f, 0)};
  p.indices = {0, 1, 2};
  p.material = {0};
  p.mesh = {0};
  p.mesh_paths = {"/Proto/Tri"};
  p.double_sided = {0};
  M44f at;
  at.setTranslation(V3f(3, 0, 0));
  s.add_instance(0, at);
  at.setTranslation(V3f(4, 0, 0));
  s.add_instance(0, at);
  Light l;
  l.prim_path = "/Key";
  l.radiance = C3f(5, 5, 5);
  s.lights.push_back(l);
  Camera c;
  c.prim_path = "/Cam";
  c.local_to_world.setTranslation(V3f(0, 0, 9));
  s.cameras[c.prim_path] = c;
  s.warnings = {"/Floor: a warning that must survive"};
  return s;
}

std::string file_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Issue 17: 6 of 17 single-bit flips in a stored entry loaded as a
// different scene. Now every flip of every bit is refused and the entry
// removed, so the caller ingests the scene again.
TEST(ChunkStore, EverySingleBitFlipIsRefusedAndTheEntryRemoved) {
  ChunkStoreOptions store_options;
  store_options.directory = temp_dir() / "flips";
  const ChunkStore store(store_options);
  const std::string key = store.key("flips", IngestOptions{});
  store.save(key, flips_scene());
  const std::string pristine = file_bytes(store.entry_path(key));
  const std::optional<Scene> loaded = store.load(key);
  ASSERT_TRUE(loaded.has_value());
  EXPECT_EQ(loaded->triangle_count(), 5u);
  EXPECT_EQ(loaded->warnings, flips_scene().warnings);

  // One warning per refused entry: thousands here.
  struct QuietLog {
    spdlog::level::level_enum was = spdlog::get_level();
    QuietLog() { spdlog::set_level(spdlog::level::err); }
    ~QuietLog() { spdlog::set_level(was); }
  } quiet;
  // Whatever else the store keeps beside the entry is restored before each
  // flip, so that every load sees one flipped bit and nothing else.
  std::vector<std::pair<fs::path, std::string>> files;
  for (const auto& e : fs::directory_iterator(store_options.directory))
    if (e.path() != store.entry_path(key)) files.emplace_back(e.path(), file_bytes(e.path()));
  size_t served = 0;
  std::vector<size_t> served_bits;
  for (size_t bit = 0; bit < 8 * pristine.size(); ++bit) {
    for (const auto& [path, bytes] : files) std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
    std::string damaged = pristine;
    damaged[bit / 8] = char(damaged[bit / 8] ^ (1 << (bit % 8)));
    std::ofstream(store.entry_path(key), std::ios::binary | std::ios::trunc) << damaged;
    if (store.load(key).has_value()) {
      ++served;
      if (served_bits.size() < 10) served_bits.push_back(bit);
      continue;
    }
    ASSERT_FALSE(store.contains(key)) << "bit " << bit << ": a refused entry is removed";
  }
  EXPECT_EQ(served, 0u) << "of " << 8 * pristine.size() << " flipped bits, e.g. "
                        << ::testing::PrintToString(served_bits);
}

// Entries of older builds (a bare SceneChunk stream, no magic) and of
// unknown versions are refused, never misread, and removed.
TEST(ChunkStore, OtherLayoutsAndVersionsAreRefusedAndRemoved) {
  ChunkStoreOptions store_options;
  store_options.directory = temp_dir() / "layouts";
  const ChunkStore store(store_options);
  const std::string key = store.key("layouts", IngestOptions{});

  pbgi::v1::SceneChunk c;
  c.mutable_header()->set_content_hash("layouts");
  c.mutable_header()->set_meters_per_unit(1.0);
  std::string bare = test::framed(c);
  c.Clear();
  c.mutable_end()->set_chunk_count(1);
  bare += test::framed(c);
  std::ofstream(store.entry_path(key), std::ios::binary) << bare;
  EXPECT_FALSE(store.load(key).has_value());
  EXPECT_FALSE(store.contains(key));

  store.save(key, flips_scene());
  std::string entry = file_bytes(store.entry_path(key));
  ASSERT_EQ(entry.substr(0, 4), "PBGS");
  // Format 4 (no SceneSize) and an unknown 6 (little-endian u32 at offset 4).
  for (const char version : {4, 6}) {
    store.save(key, flips_scene());
    std::string entry = file_bytes(store.entry_path(key));
    ASSERT_EQ(entry.substr(0, 4), "PBGS");
    ASSERT_EQ(entry[4], 5) << "entries are written in format 5";
    entry[4] = version;
    std::ofstream(store.entry_path(key), std::ios::binary | std::ios::trunc) << entry;
    EXPECT_FALSE(store.load(key).has_value()) << "version " << int(version);
    EXPECT_FALSE(store.contains(key));
  }
}

// Format 5: the entry's SceneHeader states the decoded geometry, so a
// reopen is charged whole before its first chunk (a scene that cannot fit
// is refused before anything is decoded) and its arrays are sized once,
// exactly, instead of growing to up to twice their size.
TEST(ChunkStore, AReopenIsChargedUpFrontAndItsArraysSizedExactly) {
  ChunkStoreOptions store_options;
  store_options.directory = temp_dir() / "stated";
  const ChunkStore store(store_options);
  const std::string key = store.key("stated", IngestOptions{});
  Scene scene = flips_scene();
  // A mesh of many chunks beside the small ones.
  TriangleSoup& t = scene.triangles;
  for (int i = 0; i < 3000; ++i) {
    const uint32_t base = uint32_t(t.positions.size());
    const float x = float(i % 60), y = float(i / 60);
    for (const V3f& p : {V3f(x, y, 2), V3f(x + 1, y, 2), V3f(x, y + 1, 2)}) {
      t.positions.push_back(p);
      t.normals.push_back(V3f(0, 0, 1));
      t.uvs.push_back(V2f(x / 60, y / 60));
    }
    t.indices.insert(t.indices.end(), {base, base + 1, base + 2});
    t.material.push_back(0);
    t.mesh.push_back(0);
  }
  store_options.max_triangles_per_chunk = 500;
  const ChunkStore small_chunks(store_options);
  small_chunks.save(key, scene);

  std::vector<uint64_t> told;
  const std::optional<Scene> loaded =
      small_chunks.load(key, {}, {}, [&](uint64_t bytes, const std::string&) { told.push_back(bytes); });
  ASSERT_TRUE(loaded.has_value());
  ASSERT_EQ(loaded->triangles.triangle_count(), scene.triangles.triangle_count());
  ASSERT_FALSE(told.empty());
  EXPECT_GE(told.front(), loaded->geometry_bytes() - 64 * 1024) << "charged up front (mesh path strings apart)";
  EXPECT_EQ(told.back(), loaded->geometry_bytes());
  const TriangleSoup& w = loaded->triangles;
  EXPECT_EQ(w.positions.capacity(), w.positions.size());
  EXPECT_EQ(w.normals.capacity(), w.normals.size());
  EXPECT_EQ(w.uvs.capacity(), w.uvs.size());
  EXPECT_EQ(w.indices.capacity(), w.indices.size());
  EXPECT_EQ(w.mesh.capacity(), w.mesh.size());
  EXPECT_EQ(w.material.capacity(), w.material.size());
  const TriangleSoup& p = loaded->prototypes.at(0).triangles;
  EXPECT_EQ(p.positions.capacity(), p.positions.size());
  EXPECT_EQ(p.indices.capacity(), p.indices.size());
  EXPECT_EQ(loaded->instances.capacity(), loaded->instances.size());

  // Refused at the header: nothing decoded, the whole size named.
  size_t calls = 0;
  try {
    small_chunks.load(key, {}, {}, [&](uint64_t bytes, const std::string& what) {
      ++calls;
      if (bytes > 1024) throw ResourceExhausted(what);
    });
    FAIL() << "loaded past the limit";
  } catch (const ResourceExhausted& e) {
    EXPECT_NE(std::string(e.what()).find("frame 0"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("SceneHeader stating the geometry"), std::string::npos) << e.what();
  }
  EXPECT_EQ(calls, 1u) << "the first thing told is the whole geometry";
  EXPECT_TRUE(small_chunks.contains(key)) << "a refusal is not damage: the entry stays";
}

// The flip the issue measured in pixels (a material colour), through the
// engine's entry point: the damaged entry is not served, the scene is
// ingested again and equals the first read exactly.
TEST(ChunkStore, ADamagedEntryIsIngestedAgainNotServed) {
  const fs::path scene_path = temp_dir() / "damaged.usda";
  std::ofstream(scene_path) << kStoredScene;
  ChunkStoreOptions store_options;
  store_options.directory = temp_dir() / "damaged";
  const ChunkStore store(store_options);
  bool from_store = true;
  const Scene first = read_usd_scene_cached(scene_path, IngestOptions{}, store, {}, &from_store);
  ASSERT_FALSE(from_store);
  const fs::path entry = store.entry_path(store.key(usd_content_hash(scene_path, IngestOptions{}), IngestOptions{}));
  // /Looks/Shiny's diffuseColor.y = 0.3f: field 2 of a Vec3 (tag 0x15), then the float.
  std::string bytes = file_bytes(entry);
  const float y = 0.3f;
  const size_t at = bytes.find("\x15" + std::string(reinterpret_cast<const char*>(&y), 4));
  ASSERT_NE(at, std::string::npos);
  bytes[at + 1] = char(bytes[at + 1] ^ 1);  // the lowest mantissa bit: 0.3 -> 0.30000001
  std::ofstream(entry, std::ios::binary | std::ios::trunc) << bytes;

  const Scene again = read_usd_scene_cached(scene_path, IngestOptions{}, store, {}, &from_store);
  EXPECT_FALSE(from_store);
  ASSERT_EQ(again.materials.size(), first.materials.size());
  for (size_t m = 0; m < first.materials.size(); ++m) EXPECT_EQ(again.materials[m].albedo, first.materials[m].albedo);
  ASSERT_EQ(again.triangles.positions.size(), first.triangles.positions.size());
  EXPECT_TRUE(std::equal(again.triangles.positions.begin(), again.triangles.positions.end(),
                         first.triangles.positions.begin()));
  read_usd_scene_cached(scene_path, IngestOptions{}, store, {}, &from_store);
  EXPECT_TRUE(from_store) << "the rebuilt entry is stored";
}

TEST(ChunkStore, OptionsAreValidated) {
  ChunkStoreOptions o;
  EXPECT_THROW(ChunkStore{o}, InvalidArgument);  // no directory
  o.directory = temp_dir() / "bad";
  o.draco.position_bits = 31;
  EXPECT_THROW(ChunkStore{o}, InvalidArgument);
}

}  // namespace
}  // namespace pbgi
