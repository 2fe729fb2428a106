// Scene-root confinement of everything a scene resolves (IngestOptions::
// asset_roots): a scene inside the roots that sublayers, references or
// payloads a layer outside them -- directly, by "..", or through a symlink
// inside the roots -- or names a texture, dome map, OpenVDB or Draco file
// outside them, is refused with PermissionDenied before that file is read,
// and the error never names the outside path. Both sides are checked: the
// reader process (layers, files it resolves) and the daemon's own loaders
// (textures, OpenVDB grids, scene files given directly, stored scenes).
#include "common/errors.h"
#include "server/ingest/chunk_store.h"
#include "server/ingest/draco_mesh.h"
#include "server/ingest/texture_loader.h"
#include "server/ingest/usd_ingest.h"
#include "server/volumes/scene_volumes.h"
#include "tests/server/service/temp_dir.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

const char* kSecretLayer = R"(#usda 1.0
def Mesh "Secret"
{
    uniform token subdivisionScheme = "none"
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
}
)";

// A triangle bound to a material whose diffuseColor reads `texture`.
std::string textured_scene(const std::string& texture) {
  return R"(#usda 1.0
def Mesh "Tri" (
    prepend apiSchemas = ["MaterialBindingAPI"]
)
{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    rel material:binding = </Looks/M>
}
def Scope "Looks"
{
    def Material "M"
    {
        token outputs:surface.connect = </Looks/M/Surface.outputs:surface>
        def Shader "Surface"
        {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor.connect = </Looks/M/Tex.outputs:rgb>
            token outputs:surface
        }
        def Shader "Tex"
        {
            uniform token info:id = "UsdUVTexture"
            asset inputs:file = @)" + texture + R"(@
            float3 outputs:rgb
        }
    }
}
)";
}

// A triangle bound to the material M of the MaterialX document `document`
// (materialx_looks.py reads the document itself).
std::string mtlx_scene(const std::string& document) {
  return R"(#usda 1.0
def Material "Look" (
    prepend references = @)" +
         document + R"(@</MaterialX/Materials/M>
)
{
}
def Mesh "Floor" (
    prepend apiSchemas = ["MaterialBindingAPI"]
)
{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    rel material:binding = </Look>
}
)";
}

class AssetConfinement : public ::testing::Test {
 protected:
  void SetUp() override {
    root = base / "root";
    outside = base / "elsewhere";
    fs::create_directories(root);
    fs::create_directories(outside);
    write(outside / "secret.usda", kSecretLayer);
    write(root / "inside.usda", kSecretLayer);
    write(outside / "secret.png", "not an image, never read");
    write(outside / "sky.exr", "not an image, never read");
    write(outside / "fog.vdb", "not a grid, never read");
    DracoMesh triangle;
    triangle.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    triangle.indices = {0, 1, 2};
    write(outside / "secret.drc", encode_draco_mesh(triangle, DracoOptions{}));
    fs::create_symlink(outside / "secret.usda", root / "link.usda");
    fs::create_symlink(outside, root / "linked-dir");
    fs::create_symlink(outside / "fog.vdb", root / "link.vdb");
    fs::create_symlink(outside / "secret.drc", root / "link.drc");
    confined.asset_roots = AssetRoots({root});
  }
  static void write(const fs::path& path, const std::string& text) {
    std::ofstream(path, std::ios::binary) << text;
  }

  // `scene` (written below the root) is refused by read_usd_scene and, if
  // it escapes by a layer, already by the content hash the chunk store
  // asks first (the hash reads every layer); neither error names the
  // outside directory.
  enum class Escape { kLayer, kFile };
  void expect_refused(const std::string& name, const std::string& text = "", Escape escape = Escape::kLayer) {
    const fs::path path = root / name;
    if (!text.empty()) write(path, text);
    const bool hashed = escape == Escape::kLayer;
    for (int hash_only = 0; hash_only <= (hashed ? 1 : 0); ++hash_only) {
      try {
        if (hash_only)
          usd_content_hash(path, confined);
        else
          read_usd_scene(path, confined);
        ADD_FAILURE() << name << (hash_only ? " (hash)" : "") << ": read although it uses a file outside the roots";
      } catch (const PermissionDenied& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("outside the scene roots"), std::string::npos) << message;
        EXPECT_EQ(message.find(outside.filename().string()), std::string::npos)
            << name << ": the error discloses the outside path: " << message;
        EXPECT_EQ(message.find("secret"), std::string::npos) << message;
      } catch (const std::exception& e) {
        ADD_FAILURE() << name << ": expected PermissionDenied, got: " << e.what();
      }
    }
  }

  testing::TempDir tmp;
  const fs::path base = tmp.path();
  fs::path root, outside;
  IngestOptions confined;
};

TEST_F(AssetConfinement, SublayerOutsideIsRefused) {
  expect_refused("sublayer.usda", "#usda 1.0\n(\n    subLayers = [@" + (outside / "secret.usda").string() + "@]\n)\n");
}

TEST_F(AssetConfinement, ReferenceOutsideIsRefused) {
  expect_refused("reference.usda",
                 "#usda 1.0\ndef Xform \"A\" (\n    prepend references = @../elsewhere/secret.usda@</Secret>\n)\n{\n}\n");
}

TEST_F(AssetConfinement, PayloadOutsideIsRefused) {
  expect_refused("payload.usda",
                 "#usda 1.0\ndef Xform \"A\" (\n    prepend payload = @../elsewhere/secret.usda@</Secret>\n)\n{\n}\n");
}

TEST_F(AssetConfinement, ASymlinkInsideThatLeadsOutsideIsOutside) {
  expect_refused("via-link.usda", "#usda 1.0\ndef Xform \"A\" (\n    prepend references = @./link.usda@</Secret>\n)\n{\n}\n");
  expect_refused("via-linked-dir.usda",
                 "#usda 1.0\n(\n    subLayers = [@./linked-dir/secret.usda@]\n)\n");
}

TEST_F(AssetConfinement, TextureOutsideIsRefused) {
  expect_refused("texture.usda", textured_scene("../elsewhere/secret.png"), Escape::kFile);
  expect_refused("texture-link.usda", textured_scene("./linked-dir/secret.png"), Escape::kFile);
}

TEST_F(AssetConfinement, DomeMapOutsideIsRefused) {
  expect_refused("dome.usda",
                 "#usda 1.0\ndef DomeLight \"Sky\"\n{\n    asset inputs:texture:file = @../elsewhere/sky.exr@\n}\n",
                 Escape::kFile);
}

TEST_F(AssetConfinement, OpenVdbFieldOutsideIsRefused) {
  expect_refused("volume.usda", R"(#usda 1.0
def Volume "Fog"
{
    rel field:density = </Fog/Density>
    def OpenVDBAsset "Density"
    {
        asset filePath = @../elsewhere/fog.vdb@
        token fieldName = "density"
    }
}
)",
                 Escape::kFile);
}

// A file outside the roots that does not exist is refused like one that
// does: "not found" would tell the client which files exist outside.
TEST_F(AssetConfinement, MissingFilesOutsideAreRefusedNotReportedMissing) {
  expect_refused("no-texture.usda", textured_scene("../elsewhere/none.png"), Escape::kFile);
  expect_refused("no-texture-abs.usda", textured_scene((outside / "none.png").string()), Escape::kFile);
  expect_refused("no-dome.usda",
                 "#usda 1.0\ndef DomeLight \"Sky\"\n{\n    asset inputs:texture:file = @../elsewhere/none.exr@\n}\n",
                 Escape::kFile);
  expect_refused("no-volume.usda", R"(#usda 1.0
def Volume "Fog"
{
    rel field:density = </Fog/Density>
    def OpenVDBAsset "Density"
    {
        asset filePath = @../elsewhere/none.vdb@
        token fieldName = "density"
    }
}
)",
                 Escape::kFile);
  write(root / "look.mtlx", R"(<?xml version="1.0"?>
<materialx version="1.39">
  <image name="tex" type="color3">
    <input name="file" type="filename" value="../elsewhere/none.png" />
  </image>
  <standard_surface name="SR" type="surfaceshader">
    <input name="base_color" type="color3" nodename="tex" />
  </standard_surface>
  <surfacematerial name="M" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="SR" />
  </surfacematerial>
</materialx>
)");
  expect_refused("no-mtlx-texture.usda", mtlx_scene("./look.mtlx"), Escape::kFile);
  // Inside the roots a missing texture is still a warning, not a refusal.
  write(root / "missing-inside.usda", textured_scene("./none.png"));
  const Scene scene = read_usd_scene(root / "missing-inside.usda", confined);
  EXPECT_TRUE(std::any_of(scene.warnings.begin(), scene.warnings.end(),
                          [](const std::string& w) { return w.find("not found") != std::string::npos; }));
}

// A MaterialX look (materialx_looks.py reads the document itself: usd-core
// cannot compose .mtlx) is a file the scene resolves like any other.
TEST_F(AssetConfinement, MaterialXDocumentOutsideIsRefused) {
  write(outside / "secret.mtlx", "<?xml version=\"1.0\"?>\n<materialx version=\"1.38\"/>\n");
  expect_refused("mtlx.usda", mtlx_scene("../elsewhere/secret.mtlx"));
}

// A document inside the roots that XIncludes one outside: refused before
// the include is read, by the read and by the content hash (which hashes
// the included bytes); also when the included file does not exist (the
// answer must not tell whether it does).
TEST_F(AssetConfinement, MaterialXIncludeOutsideIsRefused) {
  for (const char* include : {"../elsewhere/secret.mtlx", "../elsewhere/none.mtlx"}) {
    write(outside / "secret.mtlx", "<?xml version=\"1.0\"?>\n<materialx version=\"1.38\"/>\n");
    write(root / "look.mtlx", std::string(R"(<?xml version="1.0"?>
<materialx version="1.39" xmlns:xi="http://www.w3.org/2001/XInclude">
  <xi:include href=")") + include +
                                  R"(" />
  <standard_surface name="SR" type="surfaceshader" />
  <surfacematerial name="M" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="SR" />
  </surfacematerial>
</materialx>
)");
    expect_refused("mtlx_include.usda", mtlx_scene("./look.mtlx"));
  }
}

TEST_F(AssetConfinement, DracoFileOutsideIsRefused) {
  expect_refused("draco.usda",
                 "#usda 1.0\ndef Mesh \"D\" (\n    prepend references = @../elsewhere/secret.drc@\n)\n{\n}\n");
}

TEST_F(AssetConfinement, VdbAndDrcScenesBehindASymlinkAreRefused) {
  expect_refused("link.vdb", "", Escape::kFile);
  expect_refused("link.drc", "", Escape::kFile);
}

TEST_F(AssetConfinement, FilesInsideTheRootsAndUnconfinedReadsStillWork) {
  write(root / "ok.usda", "#usda 1.0\ndef \"A\" (\n    prepend references = @./inside.usda@</Secret>\n)\n{\n}\n");
  EXPECT_EQ(read_usd_scene(root / "ok.usda", confined).triangle_count(), 1u);
  // Local tools (no roots) read what they are given.
  write(root / "reference.usda",
        "#usda 1.0\ndef \"A\" (\n    prepend references = @../elsewhere/secret.usda@</Secret>\n)\n{\n}\n");
  EXPECT_EQ(read_usd_scene(root / "reference.usda", IngestOptions{}).triangle_count(), 1u);
}

// The daemon's loaders check on their own, before reading: a stored scene
// (chunk store) is decoded without the reader process.
TEST_F(AssetConfinement, TheDaemonsLoadersCheckBeforeReading) {
  Scene scene;
  scene.materials.emplace_back();
  scene.materials.back().prim_path = "/Looks/M";
  scene.materials.back().albedo_texture.file = (root / "linked-dir" / "secret.png").string();
  TextureLoadOptions textures;
  textures.roots = AssetRoots({root});
  try {
    load_scene_textures(scene, textures);
    ADD_FAILURE() << "texture outside the roots loaded";
  } catch (const PermissionDenied& e) {
    EXPECT_NE(std::string(e.what()).find("/Looks/M"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find("secret"), std::string::npos) << e.what();
  }

  Scene volumes;
  volumes.materials.emplace_back();
  volumes.volumes.emplace_back();
  volumes.volumes.back().prim_path = "/Fog";
  volumes.volumes.back().field = "density";
  volumes.volumes.back().file = (root / "link.vdb").string();
  VolumeOptions volume_options;
  volume_options.roots = AssetRoots({root});
  EXPECT_THROW(load_scene_volumes(volumes, volume_options), PermissionDenied);
}

TEST_F(AssetConfinement, AStoredSceneWhoseTextureNowLeadsOutsideIsRefused) {
  fs::create_directories(root / "tex");
  write(root / "tex" / "real.png", "not an image");
  fs::create_symlink(root / "tex" / "real.png", root / "albedo.png");
  write(root / "stored.usda", textured_scene("./albedo.png"));
  ChunkStoreOptions store_options;
  store_options.directory = base / "store";
  const ChunkStore store(store_options);
  bool from_store = true;
  read_usd_scene_cached(root / "stored.usda", confined, store, {}, &from_store);
  EXPECT_FALSE(from_store);
  // The layers are unchanged (same entry), but the symlink now leaves.
  fs::remove(root / "albedo.png");
  fs::create_symlink(outside / "secret.png", root / "albedo.png");
  EXPECT_THROW(read_usd_scene_cached(root / "stored.usda", confined, store), PermissionDenied);
}

}  // namespace
}  // namespace pbgi
