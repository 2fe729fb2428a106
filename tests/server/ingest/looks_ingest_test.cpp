// Materials and lights through the real reader process: UsdUVTexture on
// UsdPreviewSurface (files written here with OpenImageIO), displayColor
// per face, MaterialX approximations, dome / cylinder lights, light
// shaping and colour temperature.
#include "server/ingest/usd_ingest.h"
#include "server/scene/environment_map.h"
#include "server/scene/light_sampling.h"
#include "server/scene/surface_colors.h"
#include "server/scene/texture.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include "tests/server/ingest/scratch_files.h"
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

using test::temp_dir;

void write_image(const fs::path& path, uint32_t w, uint32_t h, uint32_t channels, const std::vector<float>& texels,
                 OIIO::TypeDesc format) {
  auto out = OIIO::ImageOutput::create(path.string());
  ASSERT_TRUE(out) << OIIO::geterror();
  OIIO::ImageSpec spec(int(w), int(h), int(channels), format);
  ASSERT_TRUE(out->open(path.string(), spec)) << out->geterror();
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, texels.data())) << out->geterror();
  out->close();
}

// 2x1 RGB PNG: left texel 128/255 grey (sRGB-encoded ~0.5), right white.
void write_png(const fs::path& path, float right = 1.f) {
  write_image(path, 2, 1, 3, {128.f / 255, 128.f / 255, 128.f / 255, right, right, right}, OIIO::TypeDesc::UINT8);
}

// sRGB decode of x (IEC 61966-2-1).
float srgb_to_linear(float x) { return x <= 0.04045f ? x / 12.92f : std::pow((x + 0.055f) / 1.055f, 2.4f); }

const char* kScene = R"(#usda 1.0
(
    upAxis = "Y"
)
def Xform "W"
{
    def Mesh "Quad" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
        texCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] (interpolation = "vertex")
        rel material:binding = </W/Looks/Auto>
    }
    def Mesh "RawQuad" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
        texCoord2f[] primvars:uv = [(0, 0), (1, 0), (1, 1), (0, 1), (9, 9)] (interpolation = "faceVarying")
        int[] primvars:uv:indices = [0, 1, 2, 3]
        rel material:binding = </W/Looks/Raw>
    }
    def Mesh "Tiled" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(0, 0, 2), (1, 0, 2), (1, 1, 2), (0, 1, 2)]
        texCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] (interpolation = "vertex")
        rel material:binding = </W/Looks/Tiled>
    }
    def Mesh "NoUvs" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 3), (1, 0, 3), (0, 1, 3)]
        rel material:binding = </W/Looks/Auto>
    }
    def Mesh "Faces"
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [3, 3]
        int[] faceVertexIndices = [0, 1, 2, 0, 2, 3]
        point3f[] points = [(0, 0, 4), (1, 0, 4), (1, 1, 4), (0, 1, 4)]
        color3f[] primvars:displayColor = [(1, 0, 0), (0, 0, 1)] (interpolation = "uniform")
    }
    def Mesh "Missing" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 5), (1, 0, 5), (0, 1, 5)]
        rel material:binding = </W/Looks/Missing>
    }
    def Mesh "Standard" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 6), (1, 0, 6), (0, 1, 6)]
        rel material:binding = </W/Looks/Mtlx>
    }
    def Mesh "Gold" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 7), (1, 0, 7), (0, 1, 7)]
        rel material:binding = </W/Looks/Gold>
    }
    def Mesh "Varnish" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 8), (1, 0, 8), (0, 1, 8)]
        rel material:binding = </W/Looks/Varnish>
    }
    def Scope "Looks"
    {
        def Material "Gold"
        {
            token outputs:surface.connect = </W/Looks/Gold/Surface.outputs:surface>
            def Shader "Surface"
            {
                uniform token info:id = "UsdPreviewSurface"
                color3f inputs:diffuseColor = (1, 0.77, 0.34)
                float inputs:metallic = 1
                float inputs:roughness = 0.1
                float inputs:ior = 2.5
                token outputs:surface
            }
        }
        def Material "Varnish"
        {
            token outputs:surface.connect = </W/Looks/Varnish/Surface.outputs:surface>
            def Shader "Surface"
            {
                uniform token info:id = "UsdPreviewSurface"
                int inputs:useSpecularWorkflow = 1
                color3f inputs:specularColor = (0.9, 0.6, 0.2)
                float inputs:roughness = 0.3
                token outputs:surface
            }
        }
        def Material "Auto"
        {
            token outputs:surface.connect = </W/Looks/Auto/Surface.outputs:surface>
            def Shader "Surface"
            {
                uniform token info:id = "UsdPreviewSurface"
                color3f inputs:diffuseColor.connect = </W/Looks/Auto/Tex.outputs:rgb>
                token outputs:surface
            }
            def Shader "St"
            {
                uniform token info:id = "UsdPrimvarReader_float2"
                string inputs:varname = "st"
                float2 outputs:result
            }
            def Shader "Tex"
            {
                uniform token info:id = "UsdUVTexture"
                asset inputs:file = @half.png@
                float2 inputs:st.connect = </W/Looks/Auto/St.outputs:result>
                token inputs:wrapS = "clamp"
                token inputs:wrapT = "clamp"
                float3 outputs:rgb
            }
        }
        def Material "Raw"
        {
            token inputs:stName = "uv"
            token outputs:surface.connect = </W/Looks/Raw/Surface.outputs:surface>
            def Shader "Surface"
            {
                uniform token info:id = "UsdPreviewSurface"
                color3f inputs:diffuseColor.connect = </W/Looks/Raw/Tex.outputs:rgb>
                color3f inputs:emissiveColor.connect = </W/Looks/Raw/Hdr.outputs:rgb>
                token outputs:surface
            }
            def Shader "St"
            {
                uniform token info:id = "UsdPrimvarReader_float2"
                token inputs:varname.connect = </W/Looks/Raw.inputs:stName>
                float2 outputs:result
            }
            def Shader "Tex"
            {
                uniform token info:id = "UsdUVTexture"
                asset inputs:file = @half.png@
                float2 inputs:st.connect = </W/Looks/Raw/St.outputs:result>
                token inputs:sourceColorSpace = "raw"
                token inputs:wrapS = "clamp"
                float4 inputs:scale = (2, 2, 2, 1)
                float4 inputs:bias = (0.1, 0.1, 0.1, 0)
                float3 outputs:rgb
            }
            def Shader "Hdr"
            {
                uniform token info:id = "UsdUVTexture"
                asset inputs:file = @half.exr@
                float2 inputs:st.connect = </W/Looks/Raw/St.outputs:result>
                token inputs:sourceColorSpace = "sRGB"
                token inputs:wrapS = "clamp"
                float3 outputs:rgb
            }
        }
        def Material "Tiled"
        {
            token outputs:surface.connect = </W/Looks/Tiled/Surface.outputs:surface>
            def Shader "Surface"
            {
                uniform token info:id = "UsdPreviewSurface"
                color3f inputs:diffuseColor.connect = </W/Looks/Tiled/Tex.outputs:rgb>
                token outputs:surface
            }
            def Shader "St"
            {
                uniform token info:id = "UsdPrimvarReader_float2"
                string inputs:varname = "st"
                float2 outputs:result
            }
            def Shader "Xf"
            {
                uniform token info:id = "UsdTransform2d"
                float2 inputs:in.connect = </W/Looks/Tiled/St.outputs:result>
                float2 inputs:scale = (2, 1)
                float2 outputs:result
            }
            def Shader "Tex"
            {
                uniform token info:id = "UsdUVTexture"
                asset inputs:file = @half.png@
                float2 inputs:st.connect = </W/Looks/Tiled/Xf.outputs:result>
                token inputs:sourceColorSpace = "raw"
                token inputs:wrapS = "repeat"
                float3 outputs:rgb
            }
        }
        def Material "Missing"
        {
            token outputs:surface.connect = </W/Looks/Missing/Surface.outputs:surface>
            def Shader "Surface"
            {
                uniform token info:id = "UsdPreviewSurface"
                color3f inputs:diffuseColor.connect = </W/Looks/Missing/Tex.outputs:rgb>
                token outputs:surface
            }
            def Shader "Tex"
            {
                uniform token info:id = "UsdUVTexture"
                asset inputs:file = @nowhere.png@
                float4 inputs:fallback = (0.3, 0.2, 0.1, 1)
                float3 outputs:rgb
            }
        }
        def Material "Mtlx"
        {
            token outputs:mtlx:surface.connect = </W/Looks/Mtlx/Std.outputs:out>
            def Shader "Std"
            {
                uniform token info:id = "ND_standard_surface_surfaceshader"
                float inputs:base = 0.5
                color3f inputs:base_color = (0.8, 0.4, 0.2)
                float inputs:metalness = 0.25
                float inputs:specular_roughness = 0.6
                token outputs:out
            }
        }
    }
    def DomeLight "Sky"
    {
        asset inputs:texture:file = @sky.exr@
        float inputs:intensity = 2
        float inputs:exposure = 1
        bool inputs:normalize = 1
    }
    def DomeLight_1 "ZSky"
    {
        uniform token poleAxis = "Z"
        color3f inputs:color = (0.5, 0.25, 1)
    }
    def CylinderLight "Tube" (
        prepend apiSchemas = ["ShapingAPI"]
    )
    {
        float inputs:radius = 0.25
        float inputs:length = 4
        float inputs:intensity = 10
        bool inputs:normalize = 1
        float inputs:shaping:cone:angle = 30
        float inputs:shaping:cone:softness = 0.2
        double3 xformOp:scale = (1, 2, 2)
        uniform token[] xformOpOrder = ["xformOp:scale"]
    }
    def SphereLight "White"
    {
        bool inputs:enableColorTemperature = 1
        float inputs:colorTemperature = 6500
    }
    def SphereLight "Warm"
    {
        bool inputs:enableColorTemperature = 1
        float inputs:colorTemperature = 3000
    }
}
)";

class LooksIngest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    write_png(temp_dir() / "half.png");
    // Float RGB, decoded as sRGB on request: 0.5 -> 0.214.
    write_image(temp_dir() / "half.exr", 2, 1, 3, {0.5f, 0.5f, 0.5f, 1.f, 1.f, 1.f}, OIIO::TypeDesc::HALF);
    // An 8x4 lat-long sky: 1 everywhere, one texel of 100.
    std::vector<float> sky(8 * 4 * 3, 1.f);
    for (int c = 0; c < 3; ++c) sky[(1 * 8 + 2) * 3 + c] = 100.f;
    write_image(temp_dir() / "sky.exr", 8, 4, 3, sky, OIIO::TypeDesc::FLOAT);
    std::ofstream(temp_dir() / "looks.usda") << kScene;
    scene_ = new Scene(read_usd_scene(temp_dir() / "looks.usda", IngestOptions{}));
  }
  static void TearDownTestSuite() {
    delete scene_;
    scene_ = nullptr;
  }
  static const Scene& scene() { return *scene_; }

  static std::vector<uint32_t> triangles_of(const std::string& prim) {
    std::vector<uint32_t> out;
    for (size_t t = 0; t < scene().triangles.triangle_count(); ++t)
      if (scene().triangles.mesh_paths[scene().triangles.mesh[t]] == prim) out.push_back(uint32_t(t));
    return out;
  }
  // Colours at world (x, y) of a unit quad prim in a plane z = const.
  static SurfaceColors at(const std::string& prim, float x, float y) {
    const TriangleSoup& t = scene().triangles;
    for (uint32_t tri : triangles_of(prim)) {
      const V3f a = t.positions[t.indices[3 * tri]], b = t.positions[t.indices[3 * tri + 1]],
                c = t.positions[t.indices[3 * tri + 2]];
      // Barycentrics in the xy plane.
      const float det = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
      const float b1 = ((x - a.x) * (c.y - a.y) - (c.x - a.x) * (y - a.y)) / det;
      const float b2 = ((b.x - a.x) * (y - a.y) - (x - a.x) * (b.y - a.y)) / det;
      if (b1 >= -1e-6f && b2 >= -1e-6f && b1 + b2 <= 1.f + 1e-6f) return surface_colors(scene(), tri, b1, b2);
    }
    ADD_FAILURE() << "no triangle of " << prim << " at " << x << ", " << y;
    return {};
  }
  static const Material& material_of(const std::string& prim) {
    return scene().materials[scene().triangles.material[triangles_of(prim).at(0)]];
  }
  static const Light& light(const std::string& path) {
    for (const Light& l : scene().lights)
      if (l.prim_path == path) return l;
    throw std::runtime_error("no light " + path);
  }
  static size_t warnings_naming(const std::string& prim, const std::string& text) {
    return std::count_if(scene().warnings.begin(), scene().warnings.end(), [&](const std::string& w) {
      return w.rfind(prim + ": ", 0) == 0 && w.find(text) != std::string::npos;
    });
  }

  static Scene* scene_;
};
Scene* LooksIngest::scene_ = nullptr;

TEST_F(LooksIngest, EightBitTextureIsDecodedFromSrgbByDefault) {
  const Material& m = material_of("/W/Quad");
  ASSERT_TRUE(m.albedo_texture.bound());
  EXPECT_EQ(m.albedo_texture.wrap_s, TextureWrap::Clamp);
  // Left texel: 128/255 sRGB -> 0.2158 linear; right: white.
  EXPECT_NEAR(at("/W/Quad", 0.2f, 0.5f).albedo.x, srgb_to_linear(128.f / 255), 2e-3f);
  EXPECT_NEAR(at("/W/Quad", 0.2f, 0.5f).albedo.x, 0.2158f, 2e-3f);
  EXPECT_NEAR(at("/W/Quad", 0.9f, 0.5f).albedo.y, 1.f, 2e-3f);
  // Decoded through the shipped OpenColorIO config, not the fallback.
  for (const std::string& w : scene().warnings) EXPECT_EQ(w.find("OpenColorIO"), std::string::npos) << w;
}

TEST_F(LooksIngest, RawTextureWithScaleBiasAndAnInterfaceVarname) {
  // varname comes from the material's inputs:stName = "uv".
  EXPECT_FALSE(scene().triangles.uvs.empty());
  const SurfaceColors c = at("/W/RawQuad", 0.2f, 0.5f);
  EXPECT_NEAR(c.albedo.x, 2.f * (128.f / 255) + 0.1f, 3e-3f);
  // The float EXR with sourceColorSpace sRGB: 0.5 -> 0.214.
  EXPECT_NEAR(c.emission.x, 0.2140f, 1e-3f);
  EXPECT_NEAR(at("/W/RawQuad", 0.9f, 0.5f).emission.z, 1.f, 2e-3f);
}

TEST_F(LooksIngest, Transform2dScalesSt) {
  // s' = 2 s with repeat: x = 0.375 -> s' = 0.75 (the right texel's
  // centre, 1); x = 0.625 -> 1.25 -> 0.25 (the left one, raw 0.502).
  EXPECT_NEAR(at("/W/Tiled", 0.375f, 0.5f).albedo.x, 1.f, 2e-3f);
  EXPECT_NEAR(at("/W/Tiled", 0.625f, 0.5f).albedo.x, 128.f / 255, 2e-3f);
}

TEST_F(LooksIngest, MeshWithoutStGetsTheTextureMeanAndAWarning) {
  const float mean = 0.5f * (srgb_to_linear(128.f / 255) + 1.f);
  EXPECT_NEAR(at("/W/NoUvs", 0.2f, 0.2f).albedo.x, mean, 2e-3f);
  EXPECT_EQ(warnings_naming("/W/NoUvs", "'st'"), 1u);
}

TEST_F(LooksIngest, UniformDisplayColorIsPerFace) {
  EXPECT_TRUE(material_of("/W/Faces").albedo_from_vertex_colors);
  EXPECT_EQ(at("/W/Faces", 0.8f, 0.2f).albedo, C3f(1, 0, 0));  // face 0, below the diagonal
  EXPECT_EQ(at("/W/Faces", 0.2f, 0.8f).albedo, C3f(0, 0, 1));
}

TEST_F(LooksIngest, MissingTextureUsesItsFallbackWithAWarning) {
  const Material& m = material_of("/W/Missing");
  EXPECT_FALSE(m.albedo_texture.bound());
  EXPECT_NEAR(m.albedo.x, 0.3f, 1e-6f);
  EXPECT_NEAR(m.albedo.z, 0.1f, 1e-6f);
  EXPECT_EQ(warnings_naming("/W/Looks/Missing", "nowhere.png"), 1u);
}

TEST_F(LooksIngest, MaterialXStandardSurfaceIsApproximated) {
  const Material& m = material_of("/W/Standard");
  EXPECT_NEAR(m.albedo.x, 0.4f, 1e-6f);
  EXPECT_NEAR(m.albedo.y, 0.2f, 1e-6f);
  EXPECT_NEAR(m.albedo.z, 0.1f, 1e-6f);
  EXPECT_NEAR(m.metallic, 0.25f, 1e-6f);
  EXPECT_NEAR(m.roughness, 0.6f, 1e-6f);
  EXPECT_EQ(warnings_naming("/W/Looks/Mtlx", "MaterialX ND_standard_surface_surfaceshader approximated"), 1u);
  // The warning names what the approximation keeps and what it drops.
  EXPECT_EQ(warnings_naming("/W/Looks/Mtlx", "GGX"), 1u);
  EXPECT_EQ(warnings_naming("/W/Looks/Mtlx", "coat, sheen, transmission"), 1u);
}

// The specular inputs of UsdPreviewSurface reach Material (server/scene/
// brdf.h builds the GGX lobe from them); unauthored ones get the spec's
// defaults (specularColor black, metallic workflow, ior 1.5).
TEST_F(LooksIngest, PreviewSurfaceSpecularInputs) {
  const Material& gold = material_of("/W/Gold");
  EXPECT_FALSE(gold.use_specular_workflow);
  EXPECT_NEAR(gold.metallic, 1.f, 1e-6f);
  EXPECT_NEAR(gold.roughness, 0.1f, 1e-6f);
  EXPECT_NEAR(gold.ior, 2.5f, 1e-6f);
  EXPECT_EQ(gold.specular_color, C3f(0, 0, 0));
  const Material& varnish = material_of("/W/Varnish");
  EXPECT_TRUE(varnish.use_specular_workflow);
  EXPECT_NEAR(varnish.specular_color.x, 0.9f, 1e-6f);
  EXPECT_NEAR(varnish.specular_color.y, 0.6f, 1e-6f);
  EXPECT_NEAR(varnish.specular_color.z, 0.2f, 1e-6f);
  EXPECT_NEAR(varnish.ior, 1.5f, 1e-6f);
  // A MaterialX approximation keeps the defaults.
  const Material& mtlx = material_of("/W/Standard");
  EXPECT_FALSE(mtlx.use_specular_workflow);
  EXPECT_NEAR(mtlx.ior, 1.5f, 1e-6f);
}

TEST_F(LooksIngest, DomeLightWithAMapIgnoresNormalize) {
  const Light& l = light("/W/Sky");
  EXPECT_EQ(l.kind, LightKind::Dome);
  ASSERT_TRUE(l.environment);
  EXPECT_EQ(l.environment->width(), 8u);
  EXPECT_NEAR(l.radiance.x, 4.f, 1e-5f);  // intensity 2 * 2^1, normalize ignored
  // Texel (2, 1): u = 2.5 / 8, v = 1.5 / 4.
  const V3f d = EnvironmentMap::uv_to_direction({2.5f / 8.f, 1.5f / 4.f});
  C3f radiance;
  float t, pdf;
  ASSERT_TRUE(intersect_light(l, V3f(0, 0, 0), d, std::numeric_limits<float>::infinity(), &radiance, &t, &pdf));
  EXPECT_NEAR(radiance.x, 400.f, 1e-2f);
}

TEST_F(LooksIngest, DomeLight1PoleAxisZRotatesTheDome) {
  const Light& l = light("/W/ZSky");
  EXPECT_EQ(l.kind, LightKind::Dome);
  EXPECT_FALSE(l.environment);
  EXPECT_EQ(l.radiance, C3f(0.5f, 0.25f, 1.f));
  V3f pole;
  l.local_to_world.multDirMatrix(V3f(0, 1, 0), pole);
  EXPECT_NEAR(pole.z, 1.f, 1e-6f);
  V3f front;
  l.local_to_world.multDirMatrix(V3f(0, 0, 1), front);
  EXPECT_NEAR(front.y, -1.f, 1e-6f);
}

TEST_F(LooksIngest, NormalizedShapedCylinder) {
  const Light& l = light("/W/Tube");
  EXPECT_EQ(l.kind, LightKind::Cylinder);
  EXPECT_FLOAT_EQ(l.radius, 0.25f);
  EXPECT_FLOAT_EQ(l.length, 4.f);
  // World area: 2 pi r * (scale y + scale z) / 2 * length * scale x.
  const float area = 2.f * float(M_PI) * 0.25f * 2.f * 4.f;
  EXPECT_NEAR(l.radiance.x, 10.f / area, 1e-5f);
  EXPECT_TRUE(l.shaping.enabled);
  EXPECT_FLOAT_EQ(l.shaping.cone_angle_degrees, 30.f);
  EXPECT_FLOAT_EQ(l.shaping.cone_softness, 0.2f);
  EXPECT_FLOAT_EQ(l.shaping.focus, 0.f);
  // Not shaped lights stay unshaped.
  EXPECT_FALSE(light("/W/White").shaping.enabled);
}

TEST_F(LooksIngest, ColorTemperature6500IsWhite) {
  const C3f w = light("/W/White").radiance;
  EXPECT_NEAR(w.x, 1.f, 1e-4f);
  EXPECT_NEAR(w.y, 1.f, 1e-4f);
  EXPECT_NEAR(w.z, 1.f, 1e-4f);
  const C3f warm = light("/W/Warm").radiance;
  EXPECT_GT(warm.x, warm.y);
  EXPECT_GT(warm.y, warm.z);
}

TEST(LooksIngestFiles, ContentHashFollowsTheTextureFiles) {
  const fs::path dir = temp_dir() / "hash";
  fs::create_directories(dir);
  std::ofstream(dir / "looks.usda") << kScene;
  write_png(dir / "half.png");
  const std::string first = read_usd_scene(dir / "looks.usda", IngestOptions{}).content_hash;
  EXPECT_EQ(read_usd_scene(dir / "looks.usda", IngestOptions{}).content_hash, first);
  write_png(dir / "half.png", 0.5f);  // same layers, another image
  EXPECT_NE(read_usd_scene(dir / "looks.usda", IngestOptions{}).content_hash, first);
}

// UsdPreviewSurface opacity and opacityThreshold (scenes/cutout_test.usda):
// a cutout whose opacity reads a texture's alpha (st sent with the mesh),
// and a constant fractional opacity; unauthored means opaque.
TEST(LooksIngestFiles, PreviewSurfaceOpacityAndThreshold) {
  const Scene s = read_usd_scene(fs::path(PBGI_TEST_SOURCE_DIR) / "scenes" / "cutout_test.usda", IngestOptions{});
  const auto find = [&](const std::string& path) -> const Material& {
    const auto it =
        std::find_if(s.materials.begin(), s.materials.end(), [&](const Material& m) { return m.prim_path == path; });
    if (it == s.materials.end()) throw std::runtime_error("no material " + path);
    return *it;
  };
  const Material& leaf = find("/World/Materials/Leaf");
  EXPECT_FLOAT_EQ(leaf.opacity_threshold, 0.5f);
  ASSERT_TRUE(leaf.opacity_texture.bound());
  EXPECT_EQ(leaf.opacity_texture.channel, TextureChannel::A);
  EXPECT_TRUE(leaf.opacity_texture.uses_uvs);
  EXPECT_FALSE(s.triangles.uvs.empty());
  const Material& veil = find("/World/Materials/Veil");
  EXPECT_FLOAT_EQ(veil.opacity, 0.5f);
  EXPECT_FLOAT_EQ(veil.opacity_threshold, 0.f);
  EXPECT_FALSE(veil.opacity_texture.bound());
  const Material& ground = find("/World/Materials/White");
  EXPECT_FLOAT_EQ(ground.opacity, 1.f);
  for (const std::string& w : s.warnings) EXPECT_EQ(w.find("opacity"), std::string::npos) << w;
}

}  // namespace
}  // namespace pbgi
