#include "client/metrics/image_comparison.h"

#include "common/errors.h"

#include <algorithm>

namespace pbgi::metrics {
namespace {

std::string name_of(const image::ExrImage& img) {
  return img.source_path().empty() ? std::string("<in-memory image>") : img.source_path();
}

std::string layer_label(const std::string& layer) {
  return layer.empty() ? std::string("beauty") : layer;
}

bool contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

}  // namespace

AovMetrics compare_layer(const image::ExrImage& test, const image::ExrImage& reference,
                         const std::string& layer, const ComparisonOptions& options,
                         const std::string& reference_layer) {
  if (test.width() != reference.width() || test.height() != reference.height())
    throw InvalidArgument("cannot compare '" + name_of(test) + "' (" +
                          std::to_string(test.width()) + "x" + std::to_string(test.height()) +
                          ") with '" + name_of(reference) + "' (" +
                          std::to_string(reference.width()) + "x" +
                          std::to_string(reference.height()) + "): sizes differ");
  AovMetrics m;
  m.layer = layer;
  m.reference_layer = reference_layer.empty() ? layer : reference_layer;
  const std::vector<std::string> ref_channels = reference.layer_channels(m.reference_layer);
  for (const std::string& s : test.layer_channels(layer))
    if (contains(ref_channels, s)) m.channels.push_back(s);
  if (m.channels.empty())
    throw NotFound("layer '" + layer_label(layer) + "' of '" + name_of(test) + "' and layer '" +
                   layer_label(m.reference_layer) + "' of '" + name_of(reference) +
                   "' share no channel");

  // 1. Error metrics over all channels of the group (interleaved alike).
  const std::vector<float> t = test.layer_interleaved(layer, m.channels);
  const std::vector<float> r = reference.layer_interleaved(m.reference_layer, m.channels);
  m.error = error_metrics(t.data(), r.data(), t.size(), options.error);

  // 2. Perceptual difference for colour or grey groups.
  if (options.perceptual) {
    const bool rgb = contains(m.channels, "R") && contains(m.channels, "G") &&
                     contains(m.channels, "B");
    const bool grey = !rgb && m.channels.size() == 1;
    if (rgb || grey) {
      std::vector<float> trgb, rrgb;
      if (rgb) {
        trgb = test.rgb(layer);
        rrgb = reference.rgb(m.reference_layer);
      } else {
        trgb.resize(t.size() * 3);
        rrgb.resize(r.size() * 3);
        for (size_t i = 0; i < t.size(); ++i)
          for (int c = 0; c < 3; ++c) {
            trgb[3 * i + c] = t[i];
            rrgb[3 * i + c] = r[i];
          }
      }
      m.perceptual = perceptual_diff(trgb, rrgb, test.width(), test.height(),
                                     options.perceptual_options);
    }
  }
  return m;
}

std::vector<AovMetrics> compare_images(const image::ExrImage& test,
                                       const image::ExrImage& reference,
                                       const ComparisonOptions& options) {
  std::vector<AovMetrics> out;
  for (const std::string& layer : test.layer_names())
    if (reference.has_layer(layer)) out.push_back(compare_layer(test, reference, layer, options));
  if (out.empty())
    throw NotFound("'" + name_of(test) + "' and '" + name_of(reference) + "' share no layer");
  return out;
}

}  // namespace pbgi::metrics
