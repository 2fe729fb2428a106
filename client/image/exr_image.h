// A multi-layer linear float image and its OpenEXR reader/writer.
//
// Channels follow the OpenEXR multi-layer naming convention: a layer is a
// channel-name prefix up to the last '.', so "direct.R" is channel "R" of
// layer "direct"; the unnamed layer "" holds the beauty ("R", "G", "B").
// The AOV layout pbgi writes (daemon tiles and reference renders alike):
//
//   layer       channels      meaning
//   ""          R G B         beauty = direct + indirect
//   direct      R G B         emission seen + direct lighting at the first hit
//   indirect    R G B         indirect lighting at the first hit
//   albedo      R G B         diffuse reflectance at the first hit
//   ao          Y             ambient accessibility (1 = unoccluded)
//
// Pixels are stored per channel (planar), row-major, y down from the top,
// always as 32-bit floats in memory; the file may hold them as half.
//
// Thread-safety: an ExrImage is a plain value; concurrent const access is
// safe, mutation needs external synchronisation. read_exr/write_exr are
// reentrant (OpenEXR's global thread pool is used for (de)compression).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace pbgi::image {

// Channel suffixes of the two layer shapes pbgi uses.
inline const std::vector<std::string>& rgb_channels() {
  static const std::vector<std::string> k{"R", "G", "B"};
  return k;
}
inline const std::vector<std::string>& y_channels() {
  static const std::vector<std::string> k{"Y"};
  return k;
}

// Full channel name of `suffix` in `layer` ("" -> "R", "direct" -> "direct.R").
std::string channel_name(const std::string& layer, const std::string& suffix);

class ExrImage {
 public:
  ExrImage() = default;
  // An image without channels; channels are added with add_channel/set_layer.
  // Throws InvalidArgument if width or height is 0.
  ExrImage(uint32_t width, uint32_t height);

  uint32_t width() const { return width_; }
  uint32_t height() const { return height_; }
  size_t pixel_count() const { return size_t(width_) * height_; }

  // --- channels (full names) ---
  // Adds a zero-filled channel, or returns the existing one unchanged.
  std::vector<float>& add_channel(const std::string& name);
  bool has_channel(const std::string& name) const;
  // Throws NotFound naming the channel (and the image's file, if known).
  const std::vector<float>& channel(const std::string& name) const;
  std::vector<float>& channel(const std::string& name);
  // All channel names, sorted (OpenEXR's order).
  std::vector<std::string> channel_names() const;

  // --- layers ---
  // Layer names present, sorted; the beauty layer is "".
  std::vector<std::string> layer_names() const;
  bool has_layer(const std::string& layer) const;
  // Channel suffixes of `layer` in their canonical order: R,G,B first (in that
  // order), then A, then the others sorted. Empty if the layer does not exist.
  std::vector<std::string> layer_channels(const std::string& layer) const;

  // Sets the channels `layer`.suffixes from pixel-interleaved data of
  // suffixes.size() floats per pixel, for the whole image (creates them).
  // Throws InvalidArgument if data.size() != pixel_count() * suffixes.size().
  void set_layer(const std::string& layer, const std::vector<std::string>& suffixes,
                 const std::vector<float>& interleaved);
  // Pixel-interleaved copy of `layer`.suffixes; throws NotFound if one is missing.
  std::vector<float> layer_interleaved(const std::string& layer,
                                       const std::vector<std::string>& suffixes) const;

  // Writes a w x h block of pixel-interleaved data at (x0, y0) into the
  // channels `layer`.suffixes (created if missing), e.g. to assemble tiles.
  // Throws InvalidArgument if the block leaves the image or data is too short.
  void set_region(const std::string& layer, const std::vector<std::string>& suffixes,
                  uint32_t x0, uint32_t y0, uint32_t w, uint32_t h, const float* interleaved);

  // Shorthands for the layer shapes above.
  void set_rgb(const std::string& layer, const std::vector<float>& rgb) {
    set_layer(layer, rgb_channels(), rgb);
  }
  std::vector<float> rgb(const std::string& layer) const {
    return layer_interleaved(layer, rgb_channels());
  }

  // Free-form string metadata, written as OpenEXR string attributes
  // (e.g. "pbgi/spp", "pbgi/scene"); read back by read_exr.
  std::map<std::string, std::string>& attributes() { return attributes_; }
  const std::map<std::string, std::string>& attributes() const { return attributes_; }

  // Where the image was read from ("" if built in memory); used in errors.
  const std::string& source_path() const { return source_path_; }
  void set_source_path(std::string path) { source_path_ = std::move(path); }

 private:
  uint32_t width_ = 0, height_ = 0;
  std::map<std::string, std::vector<float>> channels_;
  std::map<std::string, std::string> attributes_;
  std::string source_path_;
};

enum class ExrPixelType : uint8_t { Float, Half };

struct ExrWriteOptions {
  // Half halves the file and keeps ~3 significant digits: fine for display,
  // not for references that metrics are computed against (default Float).
  ExrPixelType pixel_type = ExrPixelType::Float;
  // ZIP (16 scanlines per block) is lossless and the usual choice for
  // rendered float data; the only compression offered here.
};

// Writes all channels of `image` as a single-part scanline OpenEXR file with
// ZIP compression. Writes to `path` + ".tmp" and renames, so a reader never
// sees a partial file. Throws IoError naming the file on failure,
// InvalidArgument if the image has no channels.
void write_exr(const std::string& path, const ExrImage& image,
               const ExrWriteOptions& options = {});

// Reads every channel of a single-part scanline or tiled OpenEXR file as
// float (half and uint channels are converted), and its string attributes.
// The data window becomes the image (its origin is dropped). Throws IoError
// naming the file if it cannot be opened or decoded, CorruptionError naming
// the file for a truncated or malformed file, InvalidArgument for a deep or
// multi-part file or subsampled channels.
ExrImage read_exr(const std::string& path);

}  // namespace pbgi::image
