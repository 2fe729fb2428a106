#include "client/image/png_display.h"

#include "common/errors.h"
#include "pbgi_build_config.h"

#include <OpenColorIO/OpenColorIO.h>
#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <system_error>

namespace OCIO = OCIO_NAMESPACE;

namespace pbgi::image {

std::string find_ocio_config() {
  std::string tried;
  if (const char* env = std::getenv("PBGI_OCIO_CONFIG"); env && *env) {
    if (std::filesystem::is_regular_file(env)) return env;
    tried = std::string("$PBGI_OCIO_CONFIG='") + env + "', ";
  }
  const std::string built = std::string(PBGI_SOURCE_DIR) + "/config/ocio/config.ocio";
  if (std::filesystem::is_regular_file(built)) return built;
  throw NotFound("no OpenColorIO config: tried " + tried + "'" + built + "'");
}

std::vector<uint8_t> display_rgb8(const std::vector<float>& rgb, uint32_t width,
                                  uint32_t height, const DisplayOptions& options) {
  if (rgb.size() != size_t(width) * height * 3 || width == 0 || height == 0)
    throw InvalidArgument("display_rgb8: " + std::to_string(rgb.size()) +
                          " floats for a " + std::to_string(width) + "x" +
                          std::to_string(height) + " RGB image");
  const std::string config_path =
      options.ocio_config.empty() ? find_ocio_config() : options.ocio_config;

  std::vector<float> pixels(rgb);
  // Exposure is a plain scale of linear light, so it is applied here rather
  // than through the config (which keeps the config a pure display mapping).
  if (options.exposure != 0.f) {
    const float scale = std::exp2(options.exposure);
    for (float& v : pixels) v *= scale;
  }
  try {
    OCIO::ConstConfigRcPtr config = OCIO::Config::CreateFromFile(config_path.c_str());
    const std::string display =
        options.display.empty() ? config->getDefaultDisplay() : options.display;
    const std::string view =
        options.view.empty() ? config->getDefaultView(display.c_str()) : options.view;
    OCIO::DisplayViewTransformRcPtr transform = OCIO::DisplayViewTransform::Create();
    transform->setSrc(OCIO::ROLE_SCENE_LINEAR);
    transform->setDisplay(display.c_str());
    transform->setView(view.c_str());
    OCIO::ConstCPUProcessorRcPtr cpu = config->getProcessor(transform)->getDefaultCPUProcessor();
    OCIO::PackedImageDesc desc(pixels.data(), long(width), long(height), 3);
    cpu->apply(desc);
  } catch (const OCIO::Exception& e) {
    throw Error("OpenColorIO (config '" + config_path + "', display '" + options.display +
                "', view '" + options.view + "'): " + e.what());
  }

  std::vector<uint8_t> out(pixels.size());
  for (size_t i = 0; i < pixels.size(); ++i) {
    float v = pixels[i];
    if (!(v > 0.f)) v = 0.f;  // also maps NaN to black
    out[i] = uint8_t(std::lround(std::min(v, 1.f) * 255.f));
  }
  return out;
}

void write_png(const std::string& path, const std::vector<float>& rgb, uint32_t width,
               uint32_t height, const DisplayOptions& options) {
  const std::vector<uint8_t> bytes = display_rgb8(rgb, width, height, options);

  // libpng's simplified API: no setjmp, errors come back in image.message.
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  png.width = width;
  png.height = height;
  png.format = PNG_FORMAT_RGB;
  const std::string tmp = path + ".tmp";
  if (!png_image_write_to_file(&png, tmp.c_str(), 0, bytes.data(), 0, nullptr)) {
    std::string message = png.message;
    png_image_free(&png);
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw IoError("write_png('" + path + "'): " + message);
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw IoError("write_png('" + path + "'): rename from '" + tmp + "': " + ec.message());
  }
}

void write_png(const std::string& path, const ExrImage& image, const std::string& layer,
               const DisplayOptions& options) {
  const std::vector<std::string> suffixes = image.layer_channels(layer);
  auto has = [&](const char* s) {
    return std::find(suffixes.begin(), suffixes.end(), s) != suffixes.end();
  };
  if (has("R") && has("G") && has("B")) {
    write_png(path, image.rgb(layer), image.width(), image.height(), options);
    return;
  }
  if (has("Y")) {
    const std::vector<float>& y = image.channel(channel_name(layer, "Y"));
    std::vector<float> rgb(y.size() * 3);
    for (size_t i = 0; i < y.size(); ++i) rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = y[i];
    write_png(path, rgb, image.width(), image.height(), options);
    return;
  }
  throw NotFound("write_png('" + path + "'): layer '" + layer +
                 "' has neither R,G,B nor Y channels in " +
                 (image.source_path().empty() ? std::string("the image")
                                              : "'" + image.source_path() + "'"));
}

}  // namespace pbgi::image
