// An image texture in the linear rendering space, with a box-filtered
// mip pyramid, looked up the way UsdUVTexture specifies: (s, t) with t = 0
// at the BOTTOM row of the image, texel centres at half-integers, and one of
// the black / clamp / repeat / mirror wrap modes per axis.
//
// Texels are stored as RGBA half floats (8 bytes, a third more for the
// pyramid): enough for 8-bit sRGB decoded to linear and for HDR emission.
// Images with 1 channel are grey (a = 1), 2 are grey + alpha, 3 RGB.
//
// Thread-safety: immutable after construction; lookups are safe from any
// number of threads.
#pragma once

#include "server/scene/scene.h"

#include <Imath/ImathVec.h>
#include <Imath/half.h>

#include <string>
#include <vector>

namespace pbgi {

class Texture {
 public:
  // `texels` holds width * height * channels floats, row-major, row 0 at the
  // top of the image, already linear. Throws InvalidArgument on empty or
  // inconsistent sizes or channels outside 1..4.
  Texture(std::string name, uint32_t width, uint32_t height, uint32_t channels,
          const std::vector<float>& texels);

  const std::string& name() const { return name_; }
  uint32_t width() const { return levels_[0].width; }
  uint32_t height() const { return levels_[0].height; }
  size_t level_count() const { return levels_.size(); }
  size_t memory_bytes() const;

  // Filtered RGBA at st, averaged over about `footprint` st units (the
  // width of the area the value stands for; 0 = bilinear at full
  // resolution): trilinear between the two pyramid levels around it.
  // UseMetadata wraps as Repeat (the loader resolves it from the file).
  Imath::V4f lookup(const V2f& st, TextureWrap wrap_s, TextureWrap wrap_t,
                    float footprint = 0.f) const;

  // Unfiltered texel of level 0 (x right, y down from the top row).
  Imath::V4f texel(uint32_t x, uint32_t y) const;

  // Mean over the whole image: the value for surfaces without uvs.
  const Imath::V4f& mean() const { return mean_; }

 private:
  struct Level {
    uint32_t width = 0, height = 0;
    std::vector<Imath::half> rgba;  // 4 per texel
  };
  Imath::V4f fetch(const Level& level, int64_t x, int64_t y, TextureWrap ws, TextureWrap wt) const;
  Imath::V4f bilinear(const Level& level, const V2f& st, TextureWrap ws, TextureWrap wt) const;

  std::string name_;
  std::vector<Level> levels_;
  Imath::V4f mean_{0.f, 0.f, 0.f, 1.f};
};

// The value a binding gives at st (channel selection, scale and bias
// applied; a single channel is replicated to rgb). The binding must be
// bound().
C3f evaluate_texture(const TextureBinding& binding, const V2f& st, float footprint = 0.f);

// The binding's value with st unknown: the texture's mean.
C3f evaluate_texture_mean(const TextureBinding& binding);

}  // namespace pbgi
