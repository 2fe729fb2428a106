// OpenVDB volumes: a level-set sphere made here with
// openvdb::tools::createLevelSetSphere, written to a .vdb and read through a
// UsdVol.Volume (and directly), becomes triangles on the sphere within half
// a voxel; a fog grid stays as volume data; broken fields are warnings.
#include "server/ingest/chunk_store.h"
#include "server/ingest/usd_ingest.h"
#include "server/volumes/level_set_mesh.h"
#include "server/volumes/scene_volumes.h"
#include "server/volumes/volume_grid.h"

#include "common/errors.h"

#include <gtest/gtest.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/LevelSetUtil.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

constexpr float kRadius = 1.f;
constexpr float kVoxel = 0.05f;
const openvdb::Vec3f kCenter(0.5f, 0.f, 0.f);

fs::path temp_dir() {
  static const struct Dir {
    fs::path path = fs::temp_directory_path() / ("pbgi_volume_ingest_test_" + std::to_string(getpid()));
    Dir() { fs::create_directories(path); }
    ~Dir() {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  } dir;
  return dir.path;
}

// sphere.vdb: "surface" (level set) and "density" (its fog volume).
fs::path sphere_vdb() {
  static const fs::path path = [] {
    openvdb::initialize();
    openvdb::FloatGrid::Ptr surface = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(kRadius, kCenter, kVoxel);
    surface->setName("surface");
    openvdb::FloatGrid::Ptr density = surface->deepCopy();
    openvdb::tools::sdfToFogVolume(*density);
    density->setName("density");
    const fs::path p = temp_dir() / "sphere.vdb";
    openvdb::io::File(p.string()).write({surface, density});
    return p;
  }();
  return path;
}

fs::path write_usda(const std::string& name, const std::string& text) {
  sphere_vdb();
  const fs::path p = temp_dir() / name;
  std::ofstream(p) << text;
  return p;
}

const char* kVolumeScene = R"(#usda 1.0
def Volume "Vol" (
    prepend apiSchemas = ["MaterialBindingAPI"]
)
{
    double3 xformOp:translate = (0, 10, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    rel field:surface = </Vol/Surface>
    rel field:density = </Vol/Density>
    rel material:binding = </Red>
    def OpenVDBAsset "Surface"
    {
        asset filePath = @sphere.vdb@
        token fieldName = "surface"
    }
    def OpenVDBAsset "Density"
    {
        asset filePath = @sphere.vdb@
        token fieldName = "density"
    }
}
def Volume "Broken"
{
    rel field:a = </Broken/MissingFile>
    rel field:b = </Broken/NoGrid>
    def OpenVDBAsset "MissingFile"
    {
        asset filePath = @no_such.vdb@
        token fieldName = "surface"
    }
    def OpenVDBAsset "NoGrid"
    {
        asset filePath = @sphere.vdb@
        token fieldName = "temperature"
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
)";

// Every vertex of `prim` within `tolerance` of the sphere around `center`,
// normals pointing out; returns the triangle count.
size_t expect_on_sphere(const Scene& s, const std::string& prim, const V3f& center, float tolerance) {
  const TriangleSoup& t = s.triangles;
  size_t triangles = 0;
  float worst = 0.f;
  for (size_t i = 0; i < t.triangle_count(); ++i) {
    if (t.mesh_paths[t.mesh[i]] != prim) continue;
    ++triangles;
    const V3f a = t.positions[t.indices[3 * i]], b = t.positions[t.indices[3 * i + 1]], c = t.positions[t.indices[3 * i + 2]];
    for (const V3f& p : {a, b, c}) worst = std::max(worst, std::abs((p - center).length() - kRadius));
    // Counter-clockwise around the outward normal.
    EXPECT_GT((b - a).cross(c - a).dot((a + b + c) / 3.f - center), 0.f);
    if (!t.normals.empty()) {
      const V3f n = t.normals[t.indices[3 * i]];
      EXPECT_GT(n.dot((a - center).normalized()), 0.95f);
    }
  }
  EXPECT_LE(worst, tolerance) << prim;
  return triangles;
}

TEST(VolumeIngest, LevelSetFieldBecomesTheSphereWithinHalfAVoxel) {
  const Scene s = read_usd_scene(write_usda("volume.usda", kVolumeScene), IngestOptions{});
  const V3f center(kCenter.x(), kCenter.y() + 10.f, kCenter.z());
  const size_t triangles = expect_on_sphere(s, "/Vol", center, 0.5f * kVoxel);
  // Area of the sphere at the voxel's resolution: ~ 4 pi r^2 / voxel^2 quads.
  EXPECT_GT(triangles, 3000u);
  const auto first = std::find(s.triangles.mesh_paths.begin(), s.triangles.mesh_paths.end(), "/Vol");
  ASSERT_NE(first, s.triangles.mesh_paths.end());
  for (size_t i = 0; i < s.triangles.triangle_count(); ++i)
    if (s.triangles.mesh_paths[s.triangles.mesh[i]] == "/Vol") {
      EXPECT_EQ(s.materials[s.triangles.material[i]].prim_path, "/Red");
      break;
    }

  // Both fields are listed; the fog one keeps its grid for occlusion.
  const auto field = [&](const std::string& name) -> const Volume& {
    const auto it = std::find_if(s.volumes.begin(), s.volumes.end(),
                                 [&](const Volume& v) { return v.prim_path == "/Vol" && v.field == name; });
    EXPECT_NE(it, s.volumes.end()) << name;
    return *it;
  };
  const Volume& surface = field("surface");
  EXPECT_EQ(surface.kind, VolumeKind::LevelSet);
  EXPECT_EQ(surface.triangle_count, triangles);
  const Volume& density = field("density");
  EXPECT_EQ(density.kind, VolumeKind::Fog);
  ASSERT_NE(density.grid, nullptr);
  EXPECT_NEAR(density.voxel_size, kVoxel, 1e-6f);
  EXPECT_TRUE(density.bounds.intersects(center));
  EXPECT_NEAR(density.bounds.size().x, 2.f * kRadius, 4.f * kVoxel);
  // Inside the sphere the fog is dense, outside it is empty.
  const openvdb::FloatGrid& fog = density.grid->grid();
  EXPECT_GT(fog.tree().getValue(fog.transform().worldToIndexCellCentered(openvdb::Vec3d(kCenter))), 0.9f);
  EXPECT_NE(s.content_hash.find("+vdb/"), std::string::npos);
}

TEST(VolumeIngest, BrokenFieldsAreWarningsNamingPrimAndFile) {
  const Scene s = read_usd_scene(write_usda("volume_broken.usda", kVolumeScene), IngestOptions{});
  const auto warned = [&](const std::string& text) {
    return std::any_of(s.warnings.begin(), s.warnings.end(), [&](const std::string& w) {
      return w.rfind("/Broken: ", 0) == 0 && w.find(text) != std::string::npos;
    });
  };
  EXPECT_TRUE(warned("no_such.vdb")) << ::testing::PrintToString(s.warnings);
  EXPECT_TRUE(warned("no grid named 'temperature'")) << ::testing::PrintToString(s.warnings);
  EXPECT_TRUE(std::none_of(s.triangles.mesh_paths.begin(), s.triangles.mesh_paths.end(),
                           [](const std::string& p) { return p == "/Broken"; }));
}

TEST(VolumeIngest, VdbFileGivenDirectly) {
  const Scene s = read_usd_scene(sphere_vdb(), IngestOptions{});
  expect_on_sphere(s, "/surface", V3f(kCenter.x(), kCenter.y(), kCenter.z()), 0.5f * kVoxel);
  ASSERT_EQ(s.volumes.size(), 2u);
  for (const Volume& v : s.volumes) {
    EXPECT_EQ(v.prim_path, "/" + v.field);
    EXPECT_EQ(v.kind, v.field == "density" ? VolumeKind::Fog : VolumeKind::LevelSet) << v.field;
    EXPECT_NE(v.grid, nullptr);
  }
  const fs::path garbage = temp_dir() / "garbage.vdb";
  std::ofstream(garbage) << "not a vdb";
  EXPECT_THROW(read_usd_scene(garbage, IngestOptions{}), SceneError);
}

TEST(VolumeIngest, CoarserTargetSpacingRebuildsTheLevelSet) {
  IngestOptions options;
  options.target_edge_length = 0.2f;  // four voxels: rebuilt at voxel 0.1
  const Scene coarse = read_usd_scene(sphere_vdb(), options);
  const Scene fine = read_usd_scene(sphere_vdb(), IngestOptions{});
  const size_t n = expect_on_sphere(coarse, "/surface", V3f(kCenter.x(), kCenter.y(), kCenter.z()), 0.5f * 0.1f);
  EXPECT_LT(n * 3, fine.triangles.triangle_count());
  EXPECT_NE(coarse.content_hash, fine.content_hash);
}

TEST(VolumeIngest, ChunkStoreFollowsTheVdbFile) {
  // Its own copy of the grids: the test rewrites them.
  const fs::path dir = temp_dir() / "stored";
  fs::create_directories(dir);
  fs::copy_file(sphere_vdb(), dir / "sphere.vdb", fs::copy_options::overwrite_existing);
  const fs::path scene = dir / "volume.usda";
  std::ofstream(scene) << kVolumeScene;
  ChunkStoreOptions store_options;
  store_options.directory = dir / "store";
  const ChunkStore store(store_options);

  bool from_store = true;
  const Scene first = read_usd_scene_cached(scene, IngestOptions{}, store, {}, &from_store);
  EXPECT_FALSE(from_store);
  const Scene second = read_usd_scene_cached(scene, IngestOptions{}, store, {}, &from_store);
  EXPECT_TRUE(from_store);
  EXPECT_EQ(second.triangles.triangle_count(), first.triangles.triangle_count());
  EXPECT_EQ(second.content_hash, first.content_hash);
  // Fog grids are opened again; level sets are not meshed twice.
  ASSERT_EQ(second.volumes.size(), first.volumes.size());
  for (const Volume& v : second.volumes) {
    if (v.field == "density") {
      EXPECT_NE(v.grid, nullptr);
    }
  }
  const V3f center(kCenter.x(), kCenter.y() + 10.f, kCenter.z());
  // Draco (16 bits over a ~2-unit chunk) adds < 2e-5 to the half voxel.
  expect_on_sphere(second, "/Vol", center, 0.5f * kVoxel + 1e-4f);

  // A new sphere in the same file: the USD layers are unchanged, the entry is stale.
  openvdb::FloatGrid::Ptr bigger = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(2.f * kRadius, kCenter, kVoxel);
  bigger->setName("surface");
  openvdb::FloatGrid::Ptr density = bigger->deepCopy();
  openvdb::tools::sdfToFogVolume(*density);
  density->setName("density");
  openvdb::io::File((dir / "sphere.vdb").string()).write({bigger, density});
  const Scene third = read_usd_scene_cached(scene, IngestOptions{}, store, {}, &from_store);
  EXPECT_FALSE(from_store);
  EXPECT_GT(third.triangles.triangle_count(), 3 * first.triangles.triangle_count());
}

TEST(LevelSetMesh, TransformScalesAndMirrorsKeepTheSurfaceOutward) {
  openvdb::initialize();
  const auto grid = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(1.f, openvdb::Vec3f(0.f), 0.1f);
  // Mirror x, scale by 2: a sphere of radius 2, still wound outward.
  const M44f m(-2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 1, 2, 3, 1);
  const LevelSetMesh mesh = mesh_level_set(*grid, m);
  ASSERT_GT(mesh.triangle_count(), 100u);
  EXPECT_NEAR(mesh.voxel_size, 0.2f, 1e-6f);
  const V3f c(1, 2, 3);
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    const V3f a = mesh.positions[mesh.indices[3 * t]], b = mesh.positions[mesh.indices[3 * t + 1]],
              d = mesh.positions[mesh.indices[3 * t + 2]];
    EXPECT_NEAR((a - c).length(), 2.f, 0.1f);
    EXPECT_GT((b - a).cross(d - a).dot(a - c), 0.f);
    EXPECT_GT(mesh.normals[mesh.indices[3 * t]].dot((a - c).normalized()), 0.95f);
  }
  LevelSetMeshOptions bad;
  bad.adaptivity = 2.0;
  EXPECT_THROW(mesh_level_set(*grid, m, bad), InvalidArgument);
}

}  // namespace
}  // namespace pbgi
