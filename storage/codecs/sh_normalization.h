// The domain in which SH node payloads are quantized.
//
// HDR scenes put emitters 10^6 times brighter than the dim surfaces next to
// them; clustering raw payloads would spend the whole LUT on the bright
// ones (or lose them). Instead a payload is split into
//   * a scale s = (r0 + g0 + b0) / (3 c0), the node's mean outgoing radiance
//     (r0, g0, b0: radiance DC terms, c0: coverage DC term), coded on its own
//     in the log domain (LogScaleQuantizer), and
//   * a bounded normalized data vector of kNormalizedDims = 36 floats:
//     [ r/s (9), g/s (9), b/s (9), w * coverage (9) ]
//     with w the coverage weight. For a grey node of uniform colour the
//     three radiance blocks each equal the coverage SH; colour and
//     directional structure show as departures from that.
// The LUT clusters normalized vectors, so every node gets the same relative
// accuracy whatever its brightness: |rad' - rad| / s <= |v' - v| + |s'/s - 1| |v'|.
//
// Coverage is quantized jointly with radiance (not separately, not as half
// floats): for lit nodes radiance/s is close to colour x coverage, so the
// joint vector has few more degrees of freedom than either part and one LUT
// index codes both consistently.
//
// Special cases (all documented behaviour of the quantized codec):
//  * dark nodes (s <= 0, or s below the smallest normal float): radiance is
//    exactly 0; the radiance blocks are filled as for a grey node so the
//    vector still lands among real ones and the index codes the coverage.
//  * unusual nodes (a non-finite coefficient, non-positive or non-finite
//    coverage DC, non-finite s) are "raw": stored unquantized.
//  * components below 1e-30 in magnitude are flushed to 0 (no denormals in
//    the k-means and search arithmetic; such values are far below the float
//    precision of the other components of a bounded vector).
//
// Thread-safety: pure functions and immutable value types.
#pragma once

#include "storage/tree/node.h"

#include <cstddef>
#include <cstdint>

namespace pbgi::storage {

inline constexpr size_t kNormalizedDims = 4 * sh::kCoeffs;  // 36

enum class PayloadKind : uint8_t {
  kRegular,  // scale > 0, vector normalized
  kDark,     // radiance 0; vector holds grey pseudo-radiance and coverage
  kRaw,      // store unquantized
};

struct NormalizedPayload {
  PayloadKind kind = PayloadKind::kRaw;
  float scale = 0.f;                 // s (kRegular only)
  float v[kNormalizedDims] = {};     // kRegular / kDark
};

NormalizedPayload normalize_payload(const tree::Node& node, float coverage_weight);
// Writes radiance_sh = scale * v_rad and coverage_sh = v_cov / w into node.
void denormalize_payload(const float* v, float scale, float coverage_weight, tree::Node& node);

// Log-domain uniform quantizer of the scale s over [2^lo, 2^hi]:
//   code 0                      s = 0 (dark, or s < 2^(lo - 1))
//   code 1 .. 2^bits - 2        s = 2^(lo + (code - 1) * step), step =
//                               (hi - lo) / (2^bits - 3): relative error at
//                               most 2^(step / 2) - 1
//   code 2^bits - 1 (escape)    s > 2^hi (store the node raw)
// Values in (0, 2^lo) round to 0 or 2^lo: absolute error below 2^lo.
class LogScaleQuantizer {
 public:
  LogScaleQuantizer(uint32_t bits, float log2_lo, float log2_hi);
  uint32_t bits() const { return bits_; }
  uint32_t escape_code() const { return (1u << bits_) - 1; }
  uint32_t encode(float s) const;
  float decode(uint32_t code) const;  // escape_code() decodes to 0
  // Largest relative error of a non-escaped s in [2^lo, 2^hi].
  double max_relative_error() const;

 private:
  uint32_t bits_;
  float lo_, hi_;
  double step_;
};

}  // namespace pbgi::storage
