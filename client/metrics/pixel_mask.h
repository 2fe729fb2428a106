// Comparing a region of an image: the pixels where a mask image's layer
// has a given value (e.g. the reference's albedo AOV equal to one
// material's albedo: that material's pixels), gathered into a 1-pixel-high
// image so that the usual metrics (image_comparison.h) apply to them alone.
// The perceptual metric needs the image's 2D layout and is meaningless on
// such a strip.
//
// Thread-safety: pure functions.
#pragma once

#include "client/image/exr_image.h"

#include <cstdint>
#include <string>
#include <vector>

namespace pbgi::metrics {

// Indices (row-major) of the pixels of `mask` whose channels of `layer`
// (R,G,B, or Y) are all within `tolerance` of `value`. Throws NotFound if
// the layer is missing.
std::vector<uint32_t> pixels_where(const image::ExrImage& mask, const std::string& layer,
                                   float value, float tolerance);

// The pixels `selected` of `image`, every channel, as a selected.size() x 1
// image. Throws InvalidArgument if `selected` is empty or an index is
// outside the image.
image::ExrImage select_pixels(const image::ExrImage& image, const std::vector<uint32_t>& selected);

}  // namespace pbgi::metrics
