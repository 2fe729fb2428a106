#include "client/metrics/pixel_mask.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <cmath>

namespace pbgi::metrics {

std::vector<uint32_t> pixels_where(const image::ExrImage& mask, const std::string& layer,
                                   float value, float tolerance) {
  std::vector<std::string> channels = mask.layer_channels(layer);
  if (channels.empty()) {
    throw NotFound(fmt::format("mask layer '{}' is not in the mask image", layer));
  }
  std::vector<const std::vector<float>*> data;
  for (const std::string& c : channels) {
    if (c == "A") continue;  // coverage, not a value
    data.push_back(&mask.channel(image::channel_name(layer, c)));
  }
  std::vector<uint32_t> out;
  for (size_t p = 0; p < mask.pixel_count(); ++p) {
    bool inside = true;
    for (const std::vector<float>* d : data) inside = inside && std::abs((*d)[p] - value) <= tolerance;
    if (inside) out.push_back(uint32_t(p));
  }
  return out;
}

image::ExrImage select_pixels(const image::ExrImage& image, const std::vector<uint32_t>& selected) {
  if (selected.empty()) throw InvalidArgument("select_pixels: no pixel selected");
  image::ExrImage out(uint32_t(selected.size()), 1);
  for (const std::string& name : image.channel_names()) {
    const std::vector<float>& from = image.channel(name);
    std::vector<float>& to = out.add_channel(name);
    for (size_t i = 0; i < selected.size(); ++i) {
      if (selected[i] >= from.size()) {
        throw InvalidArgument(fmt::format("select_pixels: pixel {} is outside the {}x{} image",
                                          selected[i], image.width(), image.height()));
      }
      to[i] = from[selected[i]];
    }
  }
  return out;
}

}  // namespace pbgi::metrics
