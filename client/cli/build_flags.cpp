#include "client/cli/build_flags.h"

#include "storage/format/errors.h"

namespace pbgi::cli {

void BuildArgs::add_to(CLI::App* cmd) {
  cmd->add_option("--target-surfels", target_surfels, "surfels to sample [200000]");
  cmd->add_option("--surfel-spacing", surfel_spacing, "surfel spacing, world units");
  cmd->add_option("--build-light-samples", light_samples, "shadow rays per surfel and light [16]");
  cmd->add_option("--bounces", bounces,
                  "light bounces in the image: 1 = one indirect bounce gathered at render time "
                  "(default); n > 1 adds n - 1 bounces to the surfels at build time [1..4]")
      ->check(CLI::Range(1u, 4u));
  cmd->add_option("--payload", payload, "node payload codec: sh|quantized|wavelet|auto");
}

v1::BuildOptions BuildArgs::to_proto() const {
  if (!payload.empty() && payload != "auto" && payload != "sh") {
    throw InvalidArgument("--payload " + payload +
                          ": this daemon's protocol (pbgi.v1) serves SH node payloads only; the "
                          "page codec is chosen when the tree is built (use sh or auto)");
  }
  v1::BuildOptions build;
  build.set_target_surfels(target_surfels);
  build.set_surfel_spacing(surfel_spacing);
  build.set_light_samples(light_samples);
  build.set_bounces(bounces);
  return build;
}

}  // namespace pbgi::cli
