// Display-referred PNGs of linear images through OpenColorIO.
//
// Renders are scene-linear Rec.709; a PNG is for looking at, so pixels go
// through an OCIO display transform (scene_linear -> display/view of the
// config, by default "sRGB"/"Standard": the sRGB transfer function, no tone
// map), after an optional exposure in stops, and are quantized to 8 bits.
// OCIO 2.1 has no built-in configs, so pbgi ships config/ocio/config.ocio.
//
// Thread-safety: all functions are reentrant; OCIO configs and processors
// are immutable and cached by OCIO itself.
#pragma once

#include "client/image/exr_image.h"

#include <cstdint>
#include <string>
#include <vector>

namespace pbgi::image {

struct DisplayOptions {
  // OCIO config file; "" = find_ocio_config().
  std::string ocio_config;
  // Display and view of the config ("" = the config's defaults).
  std::string display = "sRGB";
  std::string view = "Standard";
  // Scale applied to linear values before the display transform, in stops
  // (2^exposure); 0 = none.
  float exposure = 0.f;
};

// The config pbgi uses: $PBGI_OCIO_CONFIG if set, else
// <PBGI_SOURCE_DIR>/config/ocio/config.ocio of this build. Throws NotFound
// naming the paths tried if neither file exists.
std::string find_ocio_config();

// 8-bit display values (3 per pixel, row-major) of linear interleaved RGB.
// Throws InvalidArgument if rgb.size() != width*height*3, Error (with OCIO's
// message and the config path) if the config, display or view is unusable.
std::vector<uint8_t> display_rgb8(const std::vector<float>& rgb, uint32_t width,
                                  uint32_t height, const DisplayOptions& options = {});

// Writes an 8-bit RGB PNG of linear interleaved RGB pixels. Throws IoError
// naming the file if it cannot be written (the file is written to path+".tmp"
// and renamed).
void write_png(const std::string& path, const std::vector<float>& rgb, uint32_t width,
               uint32_t height, const DisplayOptions& options = {});

// Writes the RGB layer `layer` ("" = beauty) of `image` as a PNG. A layer
// with only "Y" (e.g. ao) is shown as grey. Throws NotFound if the layer
// has neither R,G,B nor Y.
void write_png(const std::string& path, const ExrImage& image, const std::string& layer = "",
               const DisplayOptions& options = {});

}  // namespace pbgi::image
