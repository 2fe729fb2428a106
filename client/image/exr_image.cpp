#include "client/image/exr_image.h"

#include "common/errors.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfMultiPartInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenEXR/ImfTestFile.h>
#include <Imath/half.h>

#include <algorithm>
#include <filesystem>
#include <system_error>

namespace pbgi::image {

std::string channel_name(const std::string& layer, const std::string& suffix) {
  return layer.empty() ? suffix : layer + "." + suffix;
}

namespace {

// Splits "a.b.R" into layer "a.b" and suffix "R" (the last '.' separates).
std::pair<std::string, std::string> split_channel(const std::string& name) {
  size_t dot = name.rfind('.');
  if (dot == std::string::npos) return {"", name};
  return {name.substr(0, dot), name.substr(dot + 1)};
}

// Canonical order inside a layer: R, G, B, A, then the rest by name.
int suffix_rank(const std::string& s) {
  if (s == "R") return 0;
  if (s == "G") return 1;
  if (s == "B") return 2;
  if (s == "A") return 3;
  return 4;
}

std::string where(const std::string& source) {
  return source.empty() ? std::string("in-memory image") : "'" + source + "'";
}

}  // namespace

ExrImage::ExrImage(uint32_t width, uint32_t height) : width_(width), height_(height) {
  if (width == 0 || height == 0)
    throw InvalidArgument("ExrImage: width and height must be > 0 (got " +
                          std::to_string(width) + "x" + std::to_string(height) + ")");
}

std::vector<float>& ExrImage::add_channel(const std::string& name) {
  if (name.empty()) throw InvalidArgument("ExrImage: empty channel name");
  auto it = channels_.find(name);
  if (it != channels_.end()) return it->second;
  return channels_.emplace(name, std::vector<float>(pixel_count(), 0.f)).first->second;
}

bool ExrImage::has_channel(const std::string& name) const { return channels_.count(name) != 0; }

const std::vector<float>& ExrImage::channel(const std::string& name) const {
  auto it = channels_.find(name);
  if (it == channels_.end())
    throw NotFound("channel '" + name + "' not in " + where(source_path_));
  return it->second;
}

std::vector<float>& ExrImage::channel(const std::string& name) {
  return const_cast<std::vector<float>&>(static_cast<const ExrImage*>(this)->channel(name));
}

std::vector<std::string> ExrImage::channel_names() const {
  std::vector<std::string> names;
  names.reserve(channels_.size());
  for (const auto& [name, _] : channels_) names.push_back(name);
  return names;
}

std::vector<std::string> ExrImage::layer_names() const {
  std::vector<std::string> layers;
  for (const auto& [name, _] : channels_) {
    std::string layer = split_channel(name).first;
    if (layers.empty() || layers.back() != layer) layers.push_back(layer);
  }
  std::sort(layers.begin(), layers.end());
  layers.erase(std::unique(layers.begin(), layers.end()), layers.end());
  return layers;
}

bool ExrImage::has_layer(const std::string& layer) const {
  return !layer_channels(layer).empty();
}

std::vector<std::string> ExrImage::layer_channels(const std::string& layer) const {
  std::vector<std::string> suffixes;
  for (const auto& [name, _] : channels_) {
    auto [l, s] = split_channel(name);
    if (l == layer) suffixes.push_back(s);
  }
  std::sort(suffixes.begin(), suffixes.end(), [](const std::string& a, const std::string& b) {
    int ra = suffix_rank(a), rb = suffix_rank(b);
    return ra != rb ? ra < rb : a < b;
  });
  return suffixes;
}

void ExrImage::set_layer(const std::string& layer, const std::vector<std::string>& suffixes,
                         const std::vector<float>& interleaved) {
  if (interleaved.size() != pixel_count() * suffixes.size())
    throw InvalidArgument("ExrImage::set_layer('" + layer + "'): got " +
                          std::to_string(interleaved.size()) + " floats, expected " +
                          std::to_string(pixel_count() * suffixes.size()));
  set_region(layer, suffixes, 0, 0, width_, height_, interleaved.data());
}

std::vector<float> ExrImage::layer_interleaved(const std::string& layer,
                                               const std::vector<std::string>& suffixes) const {
  const size_t n = suffixes.size(), count = pixel_count();
  std::vector<float> out(count * n);
  for (size_t c = 0; c < n; ++c) {
    const std::vector<float>& src = channel(channel_name(layer, suffixes[c]));
    for (size_t i = 0; i < count; ++i) out[i * n + c] = src[i];
  }
  return out;
}

void ExrImage::set_region(const std::string& layer, const std::vector<std::string>& suffixes,
                          uint32_t x0, uint32_t y0, uint32_t w, uint32_t h,
                          const float* interleaved) {
  if (uint64_t(x0) + w > width_ || uint64_t(y0) + h > height_)
    throw InvalidArgument("ExrImage::set_region('" + layer + "'): block " + std::to_string(w) +
                          "x" + std::to_string(h) + " at (" + std::to_string(x0) + "," +
                          std::to_string(y0) + ") leaves the " + std::to_string(width_) + "x" +
                          std::to_string(height_) + " image");
  if (w * h != 0 && interleaved == nullptr)
    throw InvalidArgument("ExrImage::set_region('" + layer + "'): null data");
  const size_t n = suffixes.size();
  for (size_t c = 0; c < n; ++c) {
    std::vector<float>& dst = add_channel(channel_name(layer, suffixes[c]));
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x)
        dst[size_t(y0 + y) * width_ + x0 + x] = interleaved[(size_t(y) * w + x) * n + c];
  }
}

// ---------------------------------------------------------------------------

void write_exr(const std::string& path, const ExrImage& image, const ExrWriteOptions& options) {
  if (image.channel_names().empty())
    throw InvalidArgument("write_exr('" + path + "'): image has no channels");

  Imf::Header header(int(image.width()), int(image.height()));
  header.compression() = Imf::ZIP_COMPRESSION;
  for (const auto& [key, value] : image.attributes())
    header.insert(key, Imf::StringAttribute(value));

  const bool half = options.pixel_type == ExrPixelType::Half;
  const Imf::PixelType type = half ? Imf::HALF : Imf::FLOAT;
  const std::vector<std::string> names = image.channel_names();
  // Half data needs its own buffers; float channels are written in place.
  std::vector<std::vector<Imath::half>> halves(half ? names.size() : 0);
  Imf::FrameBuffer fb;
  for (size_t i = 0; i < names.size(); ++i) {
    header.channels().insert(names[i], Imf::Channel(type));
    const std::vector<float>& src = image.channel(names[i]);
    if (half) {
      halves[i].assign(src.begin(), src.end());
      fb.insert(names[i], Imf::Slice(type, reinterpret_cast<char*>(halves[i].data()),
                                     sizeof(Imath::half), sizeof(Imath::half) * image.width()));
    } else {
      fb.insert(names[i], Imf::Slice(type, const_cast<char*>(
                                               reinterpret_cast<const char*>(src.data())),
                                     sizeof(float), sizeof(float) * image.width()));
    }
  }

  const std::string tmp = path + ".tmp";
  try {
    Imf::OutputFile file(tmp.c_str(), header);
    file.setFrameBuffer(fb);
    file.writePixels(int(image.height()));
  } catch (const std::exception& e) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw IoError("write_exr('" + path + "'): " + e.what());
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw IoError("write_exr('" + path + "'): rename from '" + tmp + "': " + ec.message());
  }
}

ExrImage read_exr(const std::string& path) {
  if (!std::filesystem::exists(path)) throw IoError("read_exr('" + path + "'): no such file");
  bool tiled = false, deep = false, multipart = false;
  if (!Imf::isOpenExrFile(path.c_str(), tiled, deep, multipart))
    throw CorruptionError("read_exr('" + path + "'): not an OpenEXR file (bad magic or header)");
  if (deep || multipart)
    throw InvalidArgument("read_exr('" + path + "'): deep or multi-part files are not supported");

  try {
    Imf::InputFile file(path.c_str());
    const Imf::Header& header = file.header();
    const Imath::Box2i dw = header.dataWindow();
    const int64_t w = int64_t(dw.max.x) - dw.min.x + 1, h = int64_t(dw.max.y) - dw.min.y + 1;
    if (w <= 0 || h <= 0 || w > (1 << 20) || h > (1 << 20))
      throw CorruptionError("read_exr('" + path + "'): bad data window " + std::to_string(w) +
                            "x" + std::to_string(h));
    ExrImage image{uint32_t(w), uint32_t(h)};
    image.set_source_path(path);

    for (auto it = header.begin(); it != header.end(); ++it)
      if (auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute()))
        image.attributes()[it.name()] = s->value();

    // Read every channel as float into its own buffer; OpenEXR converts half
    // and uint. Slice::Make offsets the base pointer by the data window origin.
    Imf::FrameBuffer fb;
    for (auto ch = header.channels().begin(); ch != header.channels().end(); ++ch) {
      if (ch.channel().xSampling != 1 || ch.channel().ySampling != 1)
        throw InvalidArgument("read_exr('" + path + "'): channel '" + ch.name() +
                              "' is subsampled (not supported)");
      std::vector<float>& dst = image.add_channel(ch.name());
      fb.insert(ch.name(), Imf::Slice::Make(Imf::FLOAT, dst.data(), dw, sizeof(float),
                                            sizeof(float) * size_t(w)));
    }
    file.setFrameBuffer(fb);
    try {
      file.readPixels(dw.min.y, dw.max.y);
    } catch (const std::exception& e) {
      throw CorruptionError("read_exr('" + path + "'): reading pixels: " + e.what());
    }
    return image;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw IoError("read_exr('" + path + "'): " + e.what());
  }
}

}  // namespace pbgi::image
