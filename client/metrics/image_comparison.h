// Per-AOV comparison of a test image against a reference image: the error
// metrics of error_metrics.h for every channel group (layer) the two images
// share, plus the perceptual difference count of perceptual_diff.h for
// groups that are RGB (R,G,B) or grey (Y, shown as R=G=B).
//
// The reference is always the second image: PSNR's peak and relMSE's
// denominator come from it.
//
// Thread-safety: pure functions.
#pragma once

#include "client/image/exr_image.h"
#include "client/metrics/error_metrics.h"
#include "client/metrics/perceptual_diff.h"

#include <optional>
#include <string>
#include <vector>

namespace pbgi::metrics {

struct ComparisonOptions {
  ErrorOptions error;
  // Run the perceptual metric on RGB / Y groups (it costs a few blurs).
  bool perceptual = true;
  PerceptualOptions perceptual_options;
};

struct AovMetrics {
  std::string layer;                   // "" = beauty
  std::string reference_layer;         // layer compared against in the reference
  std::vector<std::string> channels;   // suffixes compared, e.g. R,G,B
  ErrorMetrics error;
  std::optional<PerceptualResult> perceptual;
};

// One group: `layer` of `test` against `reference_layer` of `reference`
// ("" = same name). The channels compared are the test layer's that also
// exist in the reference layer. Throws InvalidArgument naming both files if
// the sizes differ, NotFound naming the file if a layer is missing or the
// layers share no channel.
AovMetrics compare_layer(const image::ExrImage& test, const image::ExrImage& reference,
                         const std::string& layer, const ComparisonOptions& options = {},
                         const std::string& reference_layer = "");

// Every layer present in both images, in layer_names() order.
std::vector<AovMetrics> compare_images(const image::ExrImage& test,
                                       const image::ExrImage& reference,
                                       const ComparisonOptions& options = {});

}  // namespace pbgi::metrics
