// Draco meshes (round trips within the documented error bound, .drc files
// as scenes) and the chunk store of ingested scenes.
#include "server/ingest/chunk_store.h"
#include "server/ingest/draco_mesh.h"
#include "server/ingest/usd_ingest.h"

#include "pbgi/v1/scene.pb.h"
#include "storage/format/errors.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cmath>
#include <fstream>
#include <iostream>

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
    auto frame = [&](const pbgi::v1::SceneChunk& c) {
      const std::string data = c.SerializeAsString();
      const uint32_t n = static_cast<uint32_t>(data.size());
      out.write(reinterpret_cast<const char*>(&n), 4);  // little-endian host (asserted by the decoder)
      out << data;
    };
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

TEST(ChunkStore, OptionsAreValidated) {
  ChunkStoreOptions o;
  EXPECT_THROW(ChunkStore{o}, InvalidArgument);  // no directory
  o.directory = temp_dir() / "bad";
  o.draco.position_bits = 31;
  EXPECT_THROW(ChunkStore{o}, InvalidArgument);
}

}  // namespace
}  // namespace pbgi
