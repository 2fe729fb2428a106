// `pbgi compare TEST.exr REFERENCE.exr`: error metrics of a render against a
// reference, per AOV (see client/metrics/): MSE, RMSE, PSNR (peak = the
// reference's max), relative MSE, bias and the perceptual pixel count.
#include "client/cli/command.h"
#include "client/cli/json_text.h"
#include "client/image/exr_image.h"
#include "client/metrics/image_comparison.h"
#include "client/metrics/pixel_mask.h"
#include "common/errors.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

namespace pbgi::cli {
namespace {

struct CompareArgs {
  std::string test, reference;
  std::string aov;            // "" = all common layers; "beauty" names the unnamed layer
  std::string reference_aov;  // layer of the reference to compare --aov with
  bool json = false;
  bool no_perceptual = false;
  // Only the pixels where this image's mask_aov equals mask_value
  // (client/metrics/pixel_mask.h); "" = every pixel.
  std::string mask;
  std::string mask_aov = "albedo";
  float mask_value = 0.f;
  float mask_tolerance = 1e-3f;
  metrics::ComparisonOptions options;
};

std::string layer_from_flag(const std::string& aov) { return aov == "beauty" ? "" : aov; }
std::string layer_label(const std::string& layer) { return layer.empty() ? "beauty" : layer; }

// Metrics keep 9 significant digits (bench tables compare them closely).
std::string json_number(double v) { return cli::json_number(v, 9); }

void print_json(const CompareArgs& args, const std::vector<metrics::AovMetrics>& all) {
  std::string out = fmt::format("{{\"test\": {}, \"reference\": {}, \"aovs\": [",
                                json_string(args.test), json_string(args.reference));
  for (size_t i = 0; i < all.size(); ++i) {
    const metrics::AovMetrics& m = all[i];
    const metrics::ErrorMetrics& e = m.error;
    std::string channels;
    for (const auto& c : m.channels) channels += (channels.empty() ? "" : ", ") + json_string(c);
    // PSNR is +inf for identical images and NaN without a peak; JSON has
    // neither, so it is null and "identical" tells the two apart.
    out += fmt::format(
        "{}\n  {{\"aov\": {}, \"reference_aov\": {}, \"channels\": [{}], \"values\": {}, "
        "\"nonfinite\": {}, \"mse\": {}, \"rmse\": {}, \"psnr\": {}, \"peak\": {}, "
        "\"rel_mse\": {}, \"bias\": {}, \"mean_test\": {}, \"mean_reference\": {}, "
        "\"identical\": {}",
        i ? "," : "", json_string(layer_label(m.layer)),
        json_string(layer_label(m.reference_layer)), channels, e.values, e.nonfinite,
        json_number(e.mse), json_number(e.rmse), json_number(e.psnr), json_number(e.peak),
        json_number(e.rel_mse), json_number(e.bias), json_number(e.mean_test),
        json_number(e.mean_reference), e.values > 0 && e.mse == 0.0 ? "true" : "false");
    if (m.perceptual)
      out += fmt::format(", \"perceptual\": {{\"pixels_different\": {}, \"fraction\": {}}}",
                         m.perceptual->pixels_different,
                         json_number(m.perceptual->fraction_different));
    out += "}";
  }
  out += "\n]}\n";
  std::fputs(out.c_str(), stdout);
}

void print_table(const CompareArgs& args, const std::vector<metrics::AovMetrics>& all) {
  std::printf("test %s against reference %s\n", args.test.c_str(), args.reference.c_str());
  std::printf("%-20s %-4s %11s %11s %9s %11s %11s %9s\n", "aov", "ch", "MSE", "RMSE", "PSNR dB",
              "relMSE", "bias", "pdiff %");
  for (const metrics::AovMetrics& m : all) {
    std::string name = layer_label(m.layer);
    if (m.reference_layer != m.layer) name += "~" + layer_label(m.reference_layer);
    std::string channels;
    for (const auto& c : m.channels) channels += c;
    const metrics::ErrorMetrics& e = m.error;
    const std::string psnr = std::isinf(e.psnr)  ? "inf"
                             : std::isnan(e.psnr) ? "-"
                                                  : fmt::format("{:.2f}", e.psnr);
    const std::string pdiff =
        m.perceptual ? fmt::format("{:.3f}", 100.0 * m.perceptual->fraction_different) : "-";
    std::printf("%-20s %-4s %11.4e %11.4e %9s %11.4e %11.4e %9s\n", name.c_str(),
                channels.c_str(), e.mse, e.rmse, psnr.c_str(), e.rel_mse, e.bias, pdiff.c_str());
    if (e.nonfinite > 0)
      std::printf("  (%llu non-finite values skipped)\n",
                  static_cast<unsigned long long>(e.nonfinite));
  }
}

int run(CompareArgs args) {
  image::ExrImage test = image::read_exr(args.test);
  image::ExrImage reference = image::read_exr(args.reference);
  args.options.perceptual = !args.no_perceptual;
  if (!args.mask.empty()) {
    const std::vector<uint32_t> pixels =
        metrics::pixels_where(image::read_exr(args.mask), layer_from_flag(args.mask_aov),
                              args.mask_value, args.mask_tolerance);
    if (pixels.empty()) {
      throw InvalidArgument(fmt::format("--mask {}: no pixel has {} = {}", args.mask,
                                        args.mask_aov, args.mask_value));
    }
    std::printf("%zu pixels where %s of %s is %g\n", pixels.size(), args.mask_aov.c_str(),
                args.mask.c_str(), args.mask_value);
    test = metrics::select_pixels(test, pixels);
    reference = metrics::select_pixels(reference, pixels);
    args.options.perceptual = false;  // needs the 2D layout
  }
  std::vector<metrics::AovMetrics> all;
  if (args.aov.empty()) {
    all = metrics::compare_images(test, reference, args.options);
  } else {
    all.push_back(metrics::compare_layer(test, reference, layer_from_flag(args.aov), args.options,
                                         args.reference_aov.empty()
                                             ? layer_from_flag(args.aov)
                                             : layer_from_flag(args.reference_aov)));
  }
  if (args.json)
    print_json(args, all);
  else
    print_table(args, all);
  return 0;
}

const CommandRegistrar kRegistrar("compare", [](CLI::App& app, int* exit_code) {
  auto args = std::make_shared<CompareArgs>();
  CLI::App* cmd = app.add_subcommand(
      "compare", "Error metrics of an EXR against a reference EXR, per AOV");
  cmd->add_option("test", args->test, "Image to measure (EXR)")->required();
  cmd->add_option("reference", args->reference, "Reference image (EXR)")->required();
  cmd->add_option("--aov", args->aov, "Only this AOV (layer; 'beauty' = the unnamed layer)");
  cmd->add_option("--ref-aov", args->reference_aov,
                  "Reference layer to compare --aov with (default: the same name)");
  cmd->add_option("--mask", args->mask,
                  "Only the pixels where this EXR's --mask-aov equals --mask-value (e.g. a "
                  "reference's albedo: one material's pixels); no perceptual metric");
  cmd->add_option("--mask-aov", args->mask_aov, "Layer of --mask to test (default albedo)");
  cmd->add_option("--mask-value", args->mask_value, "Value every channel must have");
  cmd->add_option("--mask-tolerance", args->mask_tolerance, "Allowed difference (default 1e-3)");
  cmd->add_flag("--json", args->json, "Machine-readable output");
  cmd->add_flag("--no-perceptual", args->no_perceptual, "Skip the perceptual metric");
  cmd->add_option("--rel-eps", args->options.error.rel_mse_epsilon, "eps of relMSE")
      ->capture_default_str();
  cmd->add_option("--fov", args->options.perceptual_options.field_of_view_degrees,
                  "Perceptual metric: horizontal field of view, degrees")
      ->capture_default_str();
  cmd->add_option("--white", args->options.perceptual_options.white_luminance,
                  "Perceptual metric: cd/m^2 of linear 1.0")
      ->capture_default_str();
  cmd->callback([args, exit_code] { *exit_code = run(*args); });
});

}  // namespace
}  // namespace pbgi::cli
