#include "server/ingest/texture_loader.h"

#include "common/errors.h"
#include "pbgi_build_config.h"
#include "server/scene/environment_map.h"
#include "server/scene/texture.h"

#include <OpenColorIO/OpenColorIO.h>
#include <OpenImageIO/imageio.h>
#include <fmt/format.h>
#include <xxhash.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace pbgi {
namespace {

namespace OCIO = OCIO_NAMESPACE;

// An image as read: float texels, row 0 at the top, with what the colour
// space decision needs.
struct Image {
  uint32_t width = 0, height = 0, channels = 0;
  std::vector<float> texels;
  bool eight_bit = false;        // stored as uint8 (sRGB by convention)
  std::string color_space;       // OIIO's oiio:ColorSpace, lower case ("" = unknown)
  std::string wrap_modes;        // "wrapmodes" metadata ("" = none)
};

Image read_image(const std::string& path) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) throw IoError(OIIO::geterror());
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0)
    throw IoError(fmt::format("{}x{} image with {} channels", spec.width, spec.height, spec.nchannels));
  Image image;
  image.width = uint32_t(spec.width);
  image.height = uint32_t(spec.height);
  image.channels = uint32_t(std::min(spec.nchannels, 4));
  image.eight_bit = spec.format == OIIO::TypeDesc::UINT8;
  image.color_space = spec.get_string_attribute("oiio:ColorSpace");
  std::transform(image.color_space.begin(), image.color_space.end(), image.color_space.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  image.wrap_modes = spec.get_string_attribute("wrapmodes");
  image.texels.resize(size_t(image.width) * image.height * image.channels);
  // Subimage 0, mip level 0, the first (up to) four channels as float.
  if (!in->read_image(0, 0, 0, int(image.channels), OIIO::TypeDesc::FLOAT, image.texels.data()))
    throw IoError(in->geterror());
  return image;
}

// sRGB -> scene-linear through OpenColorIO; built once per scene.
class SrgbDecoder {
 public:
  SrgbDecoder(const TextureLoadOptions& options, std::vector<std::string>* warnings) {
    std::string path = options.ocio_config;
    if (path.empty()) {
      const char* env = std::getenv("PBGI_OCIO_CONFIG");
      path = env && *env ? env : std::string(PBGI_SOURCE_DIR) + "/config/ocio/config.ocio";
    }
    try {
      if (!std::filesystem::is_regular_file(path)) throw NotFound("no such file");
      OCIO::ConstConfigRcPtr config = OCIO::Config::CreateFromFile(path.c_str());
      cpu_ = config->getProcessor("srgb_texture", OCIO::ROLE_SCENE_LINEAR)->getDefaultCPUProcessor();
    } catch (const std::exception& e) {
      warnings->push_back(fmt::format(
          "OpenColorIO config '{}' has no usable srgb_texture -> scene_linear ({}): decoding sRGB "
          "textures with the built-in sRGB transfer function",
          path, e.what()));
      // The same transform the shipped config declares, without a config.
      OCIO::ExponentWithLinearTransformRcPtr t = OCIO::ExponentWithLinearTransform::Create();
      const double gamma[4] = {2.4, 2.4, 2.4, 1.0}, offset[4] = {0.055, 0.055, 0.055, 0.0};
      t->setGamma(gamma);
      t->setOffset(offset);
      cpu_ = OCIO::Config::CreateRaw()->getProcessor(t)->getDefaultCPUProcessor();
    }
  }

  // In place, on RGB or RGBA texels (alpha is left alone); grey images are
  // decoded through (g, g, g).
  void decode(Image& image) const {
    if (image.channels >= 3) {
      OCIO::PackedImageDesc desc(image.texels.data(), long(image.width), long(image.height),
                                 long(image.channels));
      cpu_->apply(desc);
      return;
    }
    const size_t n = size_t(image.width) * image.height;
    for (size_t i = 0; i < n; ++i) {
      float rgb[3] = {image.texels[i * image.channels], image.texels[i * image.channels],
                      image.texels[i * image.channels]};
      cpu_->applyRGB(rgb);
      image.texels[i * image.channels] = rgb[0];
    }
  }

 private:
  OCIO::ConstCPUProcessorRcPtr cpu_;
};

bool decodes_as_srgb(const Image& image, TextureColorSpace requested) {
  switch (requested) {
    case TextureColorSpace::Srgb: return true;
    case TextureColorSpace::Raw: return false;
    case TextureColorSpace::Auto: break;
  }
  if (image.channels < 3) return false;
  if (image.color_space.find("linear") != std::string::npos || image.color_space == "raw") return false;
  return image.eight_bit || image.color_space.find("srgb") != std::string::npos;
}

// One wrap mode of "wrapmodes" metadata ("periodic,clamp", "black", ...).
TextureWrap wrap_from_metadata(const std::string& modes, int axis) {
  std::string token;
  std::stringstream in(modes);
  std::vector<std::string> tokens;
  while (std::getline(in, token, ',')) tokens.push_back(token);
  if (tokens.empty()) return TextureWrap::Repeat;
  const std::string& m = tokens[std::min<size_t>(axis, tokens.size() - 1)];
  if (m == "black") return TextureWrap::Black;
  if (m == "clamp") return TextureWrap::Clamp;
  if (m == "mirror") return TextureWrap::Mirror;
  return TextureWrap::Repeat;  // periodic, repeat, default
}

// XXH3 over the bytes of every image file read: folded into the scene's
// content hash, so that caches keyed by it notice an edited image (the
// reader hashes USD layers only). Files, not texels: a compressed file is
// a fraction of its decoded size.
class ContentDigest {
 public:
  ContentDigest() : state_(XXH3_createState(), &XXH3_freeState) { XXH3_64bits_reset(state_.get()); }
  void add(const void* data, size_t n) { XXH3_64bits_update(state_.get(), data, n); }
  void add(const std::string& s) { add(s.data(), s.size() + 1); }
  // Throws IoError if the file cannot be read.
  void add_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::vector<char> block(size_t(1) << 20);
    while (in) {
      in.read(block.data(), std::streamsize(block.size()));
      add(block.data(), size_t(in.gcount()));
    }
    if (in.bad() || !in.eof()) throw IoError("cannot read it for hashing");
  }
  uint64_t value() const { return XXH3_64bits_digest(state_.get()); }

 private:
  std::unique_ptr<XXH3_state_t, decltype(&XXH3_freeState)> state_;
};

// Bumped when decoding changes what a file turns into.
constexpr int kTextureDecodeVersion = 1;

class Loader {
 public:
  Loader(Scene& scene, const TextureLoadOptions& options)
      : scene_(scene), srgb_(options, &scene.warnings) {}

  void bind(TextureBinding& b, const std::string& owner, const char* input) {
    if (b.file.empty()) return;
    const auto key = std::make_pair(b.file, decoded_as(b));
    auto it = textures_.find(key);
    if (it == textures_.end()) {
      Entry entry;
      try {
        Image image = read_image(b.file);
        const bool srgb = decodes_as_srgb(image, b.color_space);
        if (srgb) srgb_.decode(image);
        digest(b.file, image, srgb);
        entry.wrap_modes = image.wrap_modes;
        entry.texture = std::make_shared<const Texture>(b.file, image.width, image.height, image.channels,
                                                        image.texels);
      } catch (const std::exception& e) {
        entry.error = e.what();
      }
      it = textures_.emplace(key, std::move(entry)).first;
    }
    const Entry& entry = it->second;
    if (!entry.texture) {
      // One warning per (owner, file): a scene reusing a broken file in
      // many materials names each, but only once.
      if (reported_.insert(owner + "\n" + b.file).second)
        scene_.warnings.push_back(fmt::format("{}: {} texture '{}' cannot be read ({}): using its constant value",
                                              owner, input, b.file, entry.error));
      return;
    }
    b.texture = entry.texture;
    if (b.wrap_s == TextureWrap::UseMetadata) b.wrap_s = wrap_from_metadata(entry.wrap_modes, 0);
    if (b.wrap_t == TextureWrap::UseMetadata) b.wrap_t = wrap_from_metadata(entry.wrap_modes, 1);
  }

  void bind_dome(Light& light) {
    if (light.texture_file.empty()) return;
    auto it = domes_.find(light.texture_file);
    if (it == domes_.end()) {
      std::shared_ptr<const EnvironmentMap> map;
      std::string error;
      try {
        Image image = read_image(light.texture_file);
        const bool srgb = decodes_as_srgb(image, TextureColorSpace::Auto);
        if (srgb) srgb_.decode(image);
        digest(light.texture_file, image, srgb);
        std::vector<C3f> rgb(size_t(image.width) * image.height);
        for (size_t i = 0; i < rgb.size(); ++i) {
          const float* t = &image.texels[i * image.channels];
          rgb[i] = image.channels >= 3 ? C3f(t[0], t[1], t[2]) : C3f(t[0], t[0], t[0]);
        }
        if (image.width != 2 * image.height)
          scene_.warnings.push_back(fmt::format("{}: dome map '{}' is {}x{}, not 2:1: read as lat-long anyway",
                                                light.prim_path, light.texture_file, image.width, image.height));
        map = std::make_shared<const EnvironmentMap>(light.texture_file, image.width, image.height, std::move(rgb));
      } catch (const std::exception& e) {
        error = e.what();
      }
      it = domes_.emplace(light.texture_file, std::make_pair(map, error)).first;
    }
    if (!it->second.first) {
      scene_.warnings.push_back(fmt::format("{}: dome map '{}' cannot be read ({}): a constant dome of its color",
                                            light.prim_path, light.texture_file, it->second.second));
      return;
    }
    light.environment = it->second.first;
  }

  // Appends the digest of every file read (in scene order) to the hash.
  void finish() {
    if (files_ > 0)
      scene_.content_hash += fmt::format("+textures/{}({:016x})", kTextureDecodeVersion, digest_.value());
  }

 private:
  // The decode choices are part of the key: the same file read raw and as
  // sRGB gives two textures.
  void digest(const std::string& file, const Image& image, bool srgb) {
    ++files_;
    digest_.add(file);
    const uint32_t dims[4] = {image.width, image.height, image.channels, srgb ? 1u : 0u};
    digest_.add(dims, sizeof dims);
    digest_.add_file(file);
  }

  struct Entry {
    std::shared_ptr<const Texture> texture;
    std::string wrap_modes, error;
  };
  // Auto and the explicit space it resolves to may share one decode, but
  // the resolution needs the file: key on the request.
  static int decoded_as(const TextureBinding& b) { return int(b.color_space); }

  Scene& scene_;
  SrgbDecoder srgb_;
  std::map<std::pair<std::string, int>, Entry> textures_;
  std::map<std::string, std::pair<std::shared_ptr<const EnvironmentMap>, std::string>> domes_;
  std::set<std::string> reported_;
  ContentDigest digest_;
  size_t files_ = 0;
};

// Before anything is read: a scene naming one file outside is refused whole.
void check_confined(const Scene& scene, const AssetRoots& roots) {
  const auto check = [&](const std::string& file, const std::string& owner, const char* input) {
    if (!file.empty()) roots.check(file, fmt::format("{}: the {} texture", owner, input));
  };
  for (const Material& m : scene.materials) {
    check(m.albedo_texture.file, m.prim_path, "diffuseColor");
    check(m.emission_texture.file, m.prim_path, "emissiveColor");
    check(m.opacity_texture.file, m.prim_path, "opacity");
  }
  for (const Light& l : scene.lights) check(l.texture_file, l.prim_path, "dome");
}

bool names_files(const Scene& scene) {
  for (const Material& m : scene.materials)
    if (!m.albedo_texture.file.empty() || !m.emission_texture.file.empty() || !m.opacity_texture.file.empty())
      return true;
  for (const Light& l : scene.lights)
    if (!l.texture_file.empty()) return true;
  return false;
}

}  // namespace

void load_scene_textures(Scene& scene, const TextureLoadOptions& options) {
  // Scenes without images do not touch OpenColorIO at all.
  if (!names_files(scene)) return;
  check_confined(scene, options.roots);
  Loader loader(scene, options);
  for (Material& m : scene.materials) {
    loader.bind(m.albedo_texture, m.prim_path, "diffuseColor");
    loader.bind(m.emission_texture, m.prim_path, "emissiveColor");
    loader.bind(m.opacity_texture, m.prim_path, "opacity");
  }
  for (Light& l : scene.lights)
    if (l.kind == LightKind::Dome) loader.bind_dome(l);
  loader.finish();
}

}  // namespace pbgi
