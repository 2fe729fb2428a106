// A perceptual pixel-difference count after Yee and Newman 2004, "A
// Perceptual Metric for Production Testing" (the `pdiff` tool), simplified
// for linear HDR renders. It answers "how many pixels would a viewer see as
// different", which MSE cannot: noise hidden in texture or bright areas
// (masking, Weber's law) is forgiven, flat dark gradients are not.
//
// Exactly what is implemented (per pixel; t = test, r = reference):
//  1. Colour: linear Rec.709 RGB -> CIE XYZ (D65). Linear value 1.0 is the
//     display white of `white_luminance` cd/m^2, so Y_cd = Y * white_luminance
//     (pdiff instead decodes 8-bit gamma-encoded input; ours is already
//     linear). CIE L*a*b* is taken relative to the XYZ of RGB (1,1,1).
//  2. Luminance pyramid: levels L_0 = Y_cd and L_{l+1} = L_l blurred with the
//     5-tap Burt-Adelson kernel [.05 .25 .4 .25 .05] (separable, mirrored
//     borders) with taps spaced 2^l pixels apart ("a trous"), 8 levels, all at
//     full resolution, so level l holds frequencies below ~1/2^(l+1) cycles
//     per pixel (pdiff blurs with unit spacing at every level).
//  3. Viewing geometry: the image spans `field_of_view_degrees` horizontally;
//     ppd = width / (2 tan(fov/2) * 180/pi) pixels per degree. Band l
//     (the difference L_l - L_{l+1}) has centre frequency
//     cpd_l = 0.5 ppd / 2^l cycles per degree.
//  4. Adaptation luminance: La = mean of t and r at the first level whose
//     kernel spacing 2^l reaches one degree (2^l >= ppd), clamped >= 1e-5.
//  5. Contrast per band l = 0..5: c_l = max(|t_l - t_{l+1}|, |r_l - r_{l+1}|)
//     / max(|t_{l+2}|, |r_{l+2}|, 1e-5) (band-pass over the local mean).
//  6. Elevation factor F = sum_l c_l * F_freq,l * F_mask,l / sum_l c_l,
//     clamped to [1, 10], where F_freq,l = csf(3.248, 100) / csf(cpd_l, 100)
//     (the peak sensitivity over the band's) and F_mask,l =
//     mask(c_l * csf(cpd_l, La)), with Barten's contrast sensitivity
//     csf(f, L) = A f e^(-B f) sqrt(1 + 0.06 e^(B f)),
//     A = 440 (1 + 0.7/L)^-0.2, B = 0.3 (1 + 100/L)^0.15, and Daly's
//     masking mask(x) = (1 + (0.0153 (392.498 x)^0.7)^4)^0.25.
//  7. Luminance test: the pixel differs if |t_0 - r_0| > F * tvi(La), with
//     tvi the threshold-versus-intensity function of Ward Larson, Rushmeier
//     and Piatko 1997 (as in pdiff).
//  8. Colour test (unless luminance_only): a* and b* are blurred to the
//     adaptation level (colour acuity is lower than luminance acuity); the
//     pixel differs if (da*^2 + db*^2) * color_factor * min(1, La/10) > F.
//     (Dimming the colour term below 10 cd/m^2 models mesopic vision.)
// The count of differing pixels, its fraction and a per-pixel map are
// returned; non-finite values are treated as 0.
//
// Thread-safety: pure function.
#pragma once

#include <cstdint>
#include <vector>

namespace pbgi::metrics {

struct PerceptualOptions {
  // Horizontal field of view of the image as seen by the viewer, degrees
  // (pdiff's default; a 45-degree view of a monitor). In (0, 180).
  float field_of_view_degrees = 45.f;
  // Luminance of linear 1.0, cd/m^2 (a typical display white). > 0.
  float white_luminance = 100.f;
  // Weight of the colour test (0 disables it, as luminance_only does). >= 0.
  float color_factor = 1.f;
  bool luminance_only = false;
  // Also fill PerceptualResult::map.
  bool want_map = false;
};

struct PerceptualResult {
  uint64_t pixels = 0;
  uint64_t pixels_different = 0;
  double fraction_different = 0.0;
  std::vector<uint8_t> map;  // 1 = differs, row-major (if want_map)
};

// test and reference are linear RGB, pixel-interleaved, width*height*3
// floats each. Throws InvalidArgument on size mismatch or bad options.
PerceptualResult perceptual_diff(const std::vector<float>& test_rgb,
                                 const std::vector<float>& reference_rgb, uint32_t width,
                                 uint32_t height, const PerceptualOptions& options = {});

}  // namespace pbgi::metrics
