// load_scene_textures on scenes built in code: colour spaces, sharing,
// unreadable files, dome maps and the OpenColorIO fallback.
#include "server/ingest/texture_loader.h"
#include "server/scene/environment_map.h"
#include "server/scene/texture.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

fs::path temp_dir() {
  static const struct Dir {
    fs::path path = fs::temp_directory_path() / ("pbgi_texture_loader_test_" + std::to_string(getpid()));
    Dir() { fs::create_directories(path); }
    ~Dir() {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  } dir;
  return dir.path;
}

std::string write_image(const std::string& name, uint32_t w, uint32_t h, uint32_t channels,
                        const std::vector<float>& texels, OIIO::TypeDesc format) {
  const std::string path = (temp_dir() / name).string();
  auto out = OIIO::ImageOutput::create(path);
  EXPECT_TRUE(out) << OIIO::geterror();
  EXPECT_TRUE(out->open(path, OIIO::ImageSpec(int(w), int(h), int(channels), format)));
  EXPECT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, texels.data()));
  out->close();
  return path;
}

Material textured(const std::string& prim, const std::string& file, TextureColorSpace cs) {
  Material m;
  m.prim_path = prim;
  m.albedo_texture.file = file;
  m.albedo_texture.color_space = cs;
  return m;
}

size_t count_warnings(const Scene& s, const std::string& a, const std::string& b = "") {
  return std::count_if(s.warnings.begin(), s.warnings.end(), [&](const std::string& w) {
    return w.find(a) != std::string::npos && w.find(b) != std::string::npos;
  });
}

TEST(TextureLoader, ColorSpacesAndSharing) {
  // Grey 0.5 as float (EXR) and as 8-bit (PNG, 128/255).
  const std::string exr = write_image("grey.exr", 1, 1, 3, {0.5f, 0.5f, 0.5f}, OIIO::TypeDesc::FLOAT);
  const std::string png = write_image("grey.png", 1, 1, 3, {128.f / 255, 128.f / 255, 128.f / 255}, OIIO::TypeDesc::UINT8);
  const std::string mono = write_image("mono.png", 1, 1, 1, {128.f / 255}, OIIO::TypeDesc::UINT8);
  Scene s;
  s.materials = {textured("/exr_srgb", exr, TextureColorSpace::Srgb), textured("/exr_auto", exr, TextureColorSpace::Auto),
                 textured("/png_auto", png, TextureColorSpace::Auto), textured("/png_raw", png, TextureColorSpace::Raw),
                 textured("/png_auto_again", png, TextureColorSpace::Auto),
                 textured("/mono_auto", mono, TextureColorSpace::Auto)};
  load_scene_textures(s);
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  auto value = [&](size_t i) { return s.materials[i].albedo_texture.texture->texel(0, 0).x; };
  EXPECT_NEAR(value(0), 0.2140f, 5e-4f);            // sRGB 0.5 -> linear
  EXPECT_NEAR(value(1), 0.5f, 5e-4f);               // float: auto is raw
  EXPECT_NEAR(value(2), 0.2158f, 5e-4f);            // 8-bit: auto is sRGB
  EXPECT_NEAR(value(3), 128.f / 255, 5e-4f);        // raw
  EXPECT_NEAR(value(5), 128.f / 255, 5e-4f);        // one channel: auto is raw
  // One file, one colour space: loaded once, shared.
  EXPECT_EQ(s.materials[2].albedo_texture.texture, s.materials[4].albedo_texture.texture);
  EXPECT_NE(s.materials[2].albedo_texture.texture, s.materials[3].albedo_texture.texture);
  // useMetadata without metadata is repeat.
  EXPECT_EQ(s.materials[2].albedo_texture.wrap_s, TextureWrap::Repeat);
  // The texels' files are in the content hash.
  EXPECT_NE(s.content_hash.find("+textures/"), std::string::npos);
}

TEST(TextureLoader, UnreadableFilesWarnOncePerMaterialAndStayUnbound) {
  const std::string junk = (temp_dir() / "junk.png").string();
  FILE* f = std::fopen(junk.c_str(), "wb");
  std::fputs("not a png", f);
  std::fclose(f);
  Scene s;
  s.materials = {textured("/a", junk, TextureColorSpace::Auto), textured("/b", junk, TextureColorSpace::Auto)};
  s.materials[0].emission_texture.file = (temp_dir() / "absent.exr").string();
  load_scene_textures(s);
  EXPECT_FALSE(s.materials[0].albedo_texture.bound());
  EXPECT_FALSE(s.materials[0].emission_texture.bound());
  EXPECT_EQ(count_warnings(s, "/a: diffuseColor texture", "junk.png"), 1u);
  EXPECT_EQ(count_warnings(s, "/b: diffuseColor texture", "junk.png"), 1u);
  EXPECT_EQ(count_warnings(s, "/a: emissiveColor texture", "absent.exr"), 1u);
}

TEST(TextureLoader, DomeMapsAreLoadedAndOddShapesReported) {
  std::vector<float> sky(8 * 4 * 3, 2.f);
  const std::string ok = write_image("sky.exr", 8, 4, 3, sky, OIIO::TypeDesc::HALF);
  const std::string square = write_image("square.exr", 4, 4, 3, std::vector<float>(4 * 4 * 3, 1.f), OIIO::TypeDesc::HALF);
  Scene s;
  for (const std::string& file : {ok, square, (temp_dir() / "none.exr").string()}) {
    Light l;
    l.prim_path = "/Dome" + std::to_string(s.lights.size());
    l.kind = LightKind::Dome;
    l.texture_file = file;
    s.lights.push_back(l);
  }
  load_scene_textures(s);
  ASSERT_TRUE(s.lights[0].environment);
  EXPECT_NEAR(s.lights[0].environment->mean().x, 2.f, 1e-5f);
  ASSERT_TRUE(s.lights[1].environment);
  EXPECT_EQ(count_warnings(s, "/Dome1: ", "not 2:1"), 1u);
  EXPECT_FALSE(s.lights[2].environment);
  EXPECT_EQ(count_warnings(s, "/Dome2: ", "constant dome"), 1u);
}

TEST(TextureLoader, WithoutAConfigTheBuiltInSrgbTransformIsUsed) {
  const std::string exr = write_image("grey2.exr", 1, 1, 3, {0.5f, 0.5f, 0.5f}, OIIO::TypeDesc::FLOAT);
  Scene s;
  s.materials = {textured("/m", exr, TextureColorSpace::Srgb)};
  TextureLoadOptions options;
  options.ocio_config = (temp_dir() / "missing.ocio").string();
  load_scene_textures(s, options);
  EXPECT_EQ(count_warnings(s, "OpenColorIO config", "missing.ocio"), 1u);
  EXPECT_NEAR(s.materials[0].albedo_texture.texture->texel(0, 0).x, 0.2140f, 5e-4f);
}

}  // namespace
}  // namespace pbgi
