// MaterialX looks referenced from USD (.mtlx, which usd-core cannot
// compose) are read with the MaterialX package: a textured standard_surface
// and a constant OpenPBR metal keep their colours, texture, colour space
// and specular inputs; what the model lacks is listed once per material;
// unsupported graphs and missing documents fall back with a warning.
#include "server/ingest/usd_ingest.h"
#include "tests/server/ingest/scratch_files.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

const Material& material(const Scene& s, const std::string& path) {
  const auto it = std::find_if(s.materials.begin(), s.materials.end(),
                               [&](const Material& m) { return m.prim_path == path; });
  if (it == s.materials.end()) throw std::runtime_error("no material " + path);
  return *it;
}

size_t warnings_with(const Scene& s, const std::string& text) {
  return std::count_if(s.warnings.begin(), s.warnings.end(),
                       [&](const std::string& w) { return w.find(text) != std::string::npos; });
}

TEST(MaterialXLooks, StandardSurfaceTextureAndOpenPbrConstants) {
  const Scene s = read_usd_scene(fs::path(PBGI_TEST_SOURCE_DIR) / "scenes/materialx/materialx_asset.usda",
                                 IngestOptions{});
  const Material& checker = material(s, "/World/Looks/Checker");
  // base 0.9 x (image x tint (1, 0.85, 0.7)): the tint and weight are the texture's scale.
  EXPECT_EQ(fs::path(checker.albedo_texture.file).filename(), "checker.png");
  EXPECT_EQ(checker.albedo_texture.color_space, TextureColorSpace::Srgb);
  EXPECT_EQ(checker.albedo_texture.wrap_s, TextureWrap::Repeat);
  EXPECT_NEAR(checker.albedo_texture.scale.x, 0.9f, 1e-6f);
  EXPECT_NEAR(checker.albedo_texture.scale.y, 0.9f * 0.85f, 1e-6f);
  EXPECT_NEAR(checker.albedo_texture.scale.z, 0.9f * 0.7f, 1e-6f);
  EXPECT_TRUE(checker.albedo_texture.uses_uvs);
  EXPECT_FLOAT_EQ(checker.roughness, 0.6f);
  EXPECT_FLOAT_EQ(checker.metallic, 0.f);
  EXPECT_FLOAT_EQ(checker.ior, 1.5f);  // standard_surface's specular_IOR default

  const Material& gold = material(s, "/World/Looks/Gold");
  EXPECT_NEAR(gold.albedo.x, 1.f, 1e-6f);  // OpenPBR base_weight default 1
  EXPECT_NEAR(gold.albedo.y, 0.78f, 1e-6f);
  EXPECT_NEAR(gold.albedo.z, 0.34f, 1e-6f);
  EXPECT_FLOAT_EQ(gold.metallic, 1.f);
  EXPECT_FLOAT_EQ(gold.roughness, 0.25f);
  EXPECT_FALSE(gold.albedo_texture.bound() || !gold.albedo_texture.file.empty());

  // The coat is listed once, for the gold only; the arcs are not errors.
  EXPECT_EQ(warnings_with(s, "coat_weight = 0.5"), 1u);
  EXPECT_EQ(warnings_with(s, "/World/Looks/Gold: MaterialX look looks.mtlx:M_gold: not modelled"), 1u);
  EXPECT_EQ(warnings_with(s, "/World/Looks/Checker"), 0u);
  EXPECT_EQ(warnings_with(s, "composition"), 0u);
}

TEST(MaterialXLooks, WhatCannotBeMappedIsListedAndFallsBack) {
  test::write_file("odd.mtlx", R"(<?xml version="1.0"?>
<materialx version="1.39">
  <noise3d name="n" type="color3" />
  <standard_surface name="SR" type="surfaceshader">
    <input name="base_color" type="color3" nodename="n" />
    <input name="metalness" type="float" value="0.25" />
    <input name="opacity" type="color3" value="0.5, 0.5, 0.5" />
  </standard_surface>
  <surfacematerial name="M" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="SR" />
  </surfacematerial>
  <UsdPreviewSurface name="P" type="surfaceshader" />
  <surfacematerial name="Preview" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="P" />
  </surfacematerial>
</materialx>
)");
  const fs::path scene = test::write_file("odd.usda", R"(#usda 1.0
def Material "Odd" ( prepend references = @./odd.mtlx@</MaterialX/Materials/M> ) {}
def Material "Missing" ( prepend references = @./nowhere.mtlx@</MaterialX/Materials/M> ) {}
def Material "Preview" ( prepend references = @./odd.mtlx@</MaterialX/Materials/Preview> ) {}
def Mesh "A" ( prepend apiSchemas = ["MaterialBindingAPI"] ) {
  int[] faceVertexCounts = [3]
  int[] faceVertexIndices = [0, 1, 2]
  point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
  rel material:binding = </Odd>
}
def Mesh "B" ( prepend apiSchemas = ["MaterialBindingAPI"] ) {
  int[] faceVertexCounts = [3]
  int[] faceVertexIndices = [0, 1, 2]
  point3f[] points = [(0, 0, 1), (1, 0, 1), (0, 1, 1)]
  rel material:binding = </Missing>
}
def Mesh "C" ( prepend apiSchemas = ["MaterialBindingAPI"] ) {
  int[] faceVertexCounts = [3]
  int[] faceVertexIndices = [0, 1, 2]
  point3f[] points = [(0, 0, 2), (1, 0, 2), (0, 1, 2)]
  rel material:binding = </Preview>
}
)");
  const Scene s = read_usd_scene(scene, IngestOptions{});
  const Material& odd = material(s, "/Odd");
  EXPECT_FLOAT_EQ(odd.metallic, 0.25f);  // what maps still maps
  EXPECT_NEAR(odd.albedo.x, 0.8f, 1e-6f);  // base 0.8 x the base_color default 1
  EXPECT_EQ(warnings_with(s, "base_color: node n (noise3d) is not modelled"), 1u);
  EXPECT_FLOAT_EQ(odd.opacity, 0.5f);  // mapped (surface_opacity.h), not listed
  EXPECT_EQ(warnings_with(s, "opacity ="), 0u);
  EXPECT_EQ(warnings_with(s, "/Missing: MaterialX look nowhere.mtlx:M: not modelled: cannot read the document"), 1u);
  EXPECT_EQ(warnings_with(s, "/Preview: MaterialX look odd.mtlx:Preview: not modelled: surface shader is "
                             "UsdPreviewSurface, not standard_surface or open_pbr_surface"), 1u);
}

// A look whose shader sits in an XIncluded document: read through the
// include, and the include's bytes are part of the content hash, so editing
// it rebuilds (caches are keyed by the hash).
TEST(MaterialXLooks, XIncludedDocumentsAreReadAndHashed) {
  const auto shader = [](const std::string& rgb) {
    return R"(<?xml version="1.0"?>
<materialx version="1.39">
  <standard_surface name="SR" type="surfaceshader">
    <input name="base" type="float" value="1" />
    <input name="base_color" type="color3" value=")" +
           rgb + R"(" />
  </standard_surface>
</materialx>
)";
  };
  fs::create_directories(test::temp_dir() / "xinc" / "shaders");
  test::write_file("xinc/shaders/red.mtlx", shader("0.9, 0.1, 0.1"));
  test::write_file("xinc/look.mtlx", R"(<?xml version="1.0"?>
<materialx version="1.39" xmlns:xi="http://www.w3.org/2001/XInclude">
  <xi:include href="shaders/red.mtlx" />
  <surfacematerial name="M" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="SR" />
  </surfacematerial>
</materialx>
)");
  const fs::path scene = test::write_file("xinc/scene.usda", R"(#usda 1.0
def Material "Look" ( prepend references = @./look.mtlx@</MaterialX/Materials/M> ) {}
def Mesh "A" ( prepend apiSchemas = ["MaterialBindingAPI"] ) {
  int[] faceVertexCounts = [3]
  int[] faceVertexIndices = [0, 1, 2]
  point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
  rel material:binding = </Look>
}
)");
  const Scene s = read_usd_scene(scene, IngestOptions{});
  EXPECT_NEAR(material(s, "/Look").albedo.x, 0.9f, 1e-6f);
  EXPECT_NEAR(material(s, "/Look").albedo.y, 0.1f, 1e-6f);
  const std::string before = usd_content_hash(scene, IngestOptions{});
  EXPECT_EQ(s.content_hash.substr(0, before.size()), before);
  test::write_file("xinc/shaders/red.mtlx", shader("0.1, 0.9, 0.1"));
  EXPECT_NE(usd_content_hash(scene, IngestOptions{}), before);
  EXPECT_NEAR(material(read_usd_scene(scene, IngestOptions{}), "/Look").albedo.y, 0.9f, 1e-6f);
}

// OpenPBR geometry_opacity (a float) and standard_surface opacity (a
// colour: its mean) map to the material's fractional opacity.
TEST(MaterialXLooks, OpacityIsMapped) {
  test::write_file("opacity.mtlx", R"(<?xml version="1.0"?>
<materialx version="1.39">
  <open_pbr_surface name="SR_pbr" type="surfaceshader">
    <input name="geometry_opacity" type="float" value="0.25" />
  </open_pbr_surface>
  <surfacematerial name="Pbr" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="SR_pbr" />
  </surfacematerial>
  <standard_surface name="SR_std" type="surfaceshader">
    <input name="opacity" type="color3" value="0.2, 0.4, 0.6" />
  </standard_surface>
  <surfacematerial name="Std" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="SR_std" />
  </surfacematerial>
</materialx>
)");
  const fs::path scene = test::write_file("opacity.usda", R"(#usda 1.0
def Material "Pbr" ( prepend references = @./opacity.mtlx@</MaterialX/Materials/Pbr> ) {}
def Material "Std" ( prepend references = @./opacity.mtlx@</MaterialX/Materials/Std> ) {}
def Mesh "A" ( prepend apiSchemas = ["MaterialBindingAPI"] ) {
  int[] faceVertexCounts = [3]
  int[] faceVertexIndices = [0, 1, 2]
  point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
  rel material:binding = </Pbr>
}
def Mesh "B" ( prepend apiSchemas = ["MaterialBindingAPI"] ) {
  int[] faceVertexCounts = [3]
  int[] faceVertexIndices = [0, 1, 2]
  point3f[] points = [(0, 0, 1), (1, 0, 1), (0, 1, 1)]
  rel material:binding = </Std>
}
)");
  const Scene s = read_usd_scene(scene, IngestOptions{});
  EXPECT_FLOAT_EQ(material(s, "/Pbr").opacity, 0.25f);
  EXPECT_NEAR(material(s, "/Std").opacity, 0.4f, 1e-6f);
  EXPECT_FLOAT_EQ(material(s, "/Std").opacity_threshold, 0.f);
  EXPECT_EQ(warnings_with(s, "opacity"), 0u);
}

}  // namespace
}  // namespace pbgi
