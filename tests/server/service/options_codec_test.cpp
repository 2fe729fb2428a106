// Proto options <-> stage options: unset fields take the daemon's defaults,
// set fields win, invalid values are refused naming the field.
#include "server/service/options_codec.h"

#include "common/errors.h"

#include <gtest/gtest.h>

namespace pbgi::service {
namespace {

RenderOptions custom_render_defaults() {
  RenderOptions d;
  d.gather.microbuffer_resolution = 12;
  d.gather.max_solid_angle = 0.05f;
  d.gather.ao_max_distance = 3.f;
  d.gather.glossy_max_resolution = 48;
  d.gather.glossy_importance = 0.02f;
  d.gather.glossy_radiance_weight = 0.25f;
  d.gather.bent_normal = true;
  d.light_samples = 7;
  d.pixel_samples = 2;
  return d;
}

TEST(OptionsCodec, UnsetGatherFieldsTakeDaemonDefaults) {
  const RenderOptions defaults = custom_render_defaults();
  const RenderOptions r = decode_render_options(v1::GatherOptions(), defaults);
  EXPECT_EQ(r.gather.microbuffer_resolution, 12u);
  EXPECT_FLOAT_EQ(r.gather.max_solid_angle, 0.05f);
  EXPECT_FLOAT_EQ(r.gather.ao_max_distance, 3.f);
  EXPECT_EQ(r.light_samples, 7u);
  EXPECT_EQ(r.pixel_samples, 2u);
}

TEST(OptionsCodec, SetGatherFieldsOverrideDefaults) {
  v1::GatherOptions proto;
  proto.set_method(v1::GatherOptions::PBGI);
  proto.set_microbuffer_resolution(16);
  proto.set_max_solid_angle(0.01f);
  proto.set_light_samples(4);
  proto.set_glossy_max_resolution(64);
  proto.set_glossy_importance(0.05f);
  proto.set_glossy_radiance_weight(0.f);  // the lobe alone, not "the default"
  const RenderOptions r = decode_render_options(proto, custom_render_defaults());
  EXPECT_EQ(r.gather.glossy_radiance_weight, 0.f);
  EXPECT_EQ(decode_render_options(v1::GatherOptions{}, custom_render_defaults()).gather.glossy_radiance_weight,
            custom_render_defaults().gather.glossy_radiance_weight);
  EXPECT_EQ(r.gather.glossy_max_resolution, 64u);
  EXPECT_FLOAT_EQ(r.gather.glossy_importance, 0.05f);
  EXPECT_EQ(r.gather.microbuffer_resolution, 16u);
  EXPECT_FLOAT_EQ(r.gather.max_solid_angle, 0.01f);
  EXPECT_FLOAT_EQ(r.gather.ao_max_distance, 3.f);  // still the default
  EXPECT_EQ(r.light_samples, 4u);
  EXPECT_EQ(r.pixel_samples, 2u);
}

TEST(OptionsCodec, GlossyOptionsAreValidated) {
  v1::GatherOptions proto;
  proto.set_glossy_max_resolution(128);
  EXPECT_THROW(decode_gather_options(proto, GatherOptions{}), InvalidArgument);
  proto.set_glossy_max_resolution(0);
  proto.set_glossy_importance(2.f);
  EXPECT_THROW(decode_gather_options(proto, GatherOptions{}), InvalidArgument);
  proto.set_glossy_importance(0.f);
  proto.set_glossy_radiance_weight(1.5f);
  EXPECT_THROW(decode_gather_options(proto, GatherOptions{}), InvalidArgument);
}

TEST(OptionsCodec, EncodeDecodeRoundTrip) {
  const RenderOptions original = custom_render_defaults();
  const RenderOptions back = decode_render_options(encode_render_options(original), RenderOptions());
  EXPECT_EQ(back.gather.microbuffer_resolution, original.gather.microbuffer_resolution);
  EXPECT_EQ(back.gather.max_solid_angle, original.gather.max_solid_angle);
  EXPECT_EQ(back.gather.ao_max_distance, original.gather.ao_max_distance);
  EXPECT_EQ(back.light_samples, original.light_samples);
  EXPECT_EQ(back.pixel_samples, original.pixel_samples);
  EXPECT_EQ(back.gather.glossy_max_resolution, original.gather.glossy_max_resolution);
  EXPECT_EQ(back.gather.glossy_importance, original.gather.glossy_importance);
  EXPECT_EQ(back.gather.glossy_radiance_weight, original.gather.glossy_radiance_weight);
  EXPECT_EQ(back.gather.bent_normal, original.gather.bent_normal);

  OpenOptions open;
  open.surfels.spacing = 0.02f;
  open.surfels.target_surfels = 5000;
  open.surfels.light_samples = 3;
  open.tree.page_size = 32768;
  open.tree.leaf_size = 8;
  open.tree.payload_codec = tree::PayloadCodecOption::kQuantizedSh;
  open.tree.lut_entries = 10000;
  open.tree.lut_sample_fraction = 0.05;
  const OpenOptions open_back = decode_open_options(encode_open_options(open), OpenOptions());
  EXPECT_EQ(open_options_key(open_back), open_options_key(open));
  EXPECT_EQ(open_back.tree.payload_codec, tree::PayloadCodecOption::kQuantizedSh);
  EXPECT_EQ(open_back.tree.lut_entries, 10000u);
  // Unset fields keep the defaults; a bad name is refused.
  v1::BuildOptions empty;
  EXPECT_EQ(decode_open_options(empty, open).tree.payload_codec, tree::PayloadCodecOption::kQuantizedSh);
  empty.set_payload_codec("zip");
  EXPECT_THROW(decode_open_options(empty, OpenOptions()), InvalidArgument);
}

TEST(OptionsCodec, MapsMethods) {
  v1::GatherOptions proto;
  GatherOptions defaults;
  defaults.method = GatherMethod::kFpbgi;
  EXPECT_EQ(decode_gather_options(proto, defaults).method, GatherMethod::kFpbgi) << "unset: default";
  proto.set_method(v1::GatherOptions::PBGI);
  EXPECT_EQ(decode_gather_options(proto, defaults).method, GatherMethod::kPbgi);
  proto.set_method(v1::GatherOptions::FPBGI);
  proto.set_clusters(50);
  proto.set_epsilon(0.02f);
  const GatherOptions g = decode_gather_options(proto, GatherOptions());
  EXPECT_EQ(g.method, GatherMethod::kFpbgi);
  EXPECT_EQ(g.clusters, 50u);
  EXPECT_FLOAT_EQ(g.epsilon, 0.02f);
}

TEST(OptionsCodec, RefusesUnknownMethodNamingTheField) {
  // A newer client's enum value, as it arrives on the wire (field 1 = 7).
  v1::GatherOptions proto;
  ASSERT_TRUE(proto.ParseFromString(std::string("\x08\x07", 2)));
  try {
    decode_gather_options(proto, GatherOptions());
    FAIL() << "expected InvalidArgument";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("GatherOptions.method"), std::string::npos) << e.what();
  }
}

TEST(OptionsCodec, RefusesOutOfRangeMicrobuffer) {
  v1::GatherOptions proto;
  proto.set_microbuffer_resolution(1000);
  try {
    decode_gather_options(proto, GatherOptions());
    FAIL() << "expected InvalidArgument";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("microbuffer"), std::string::npos) << e.what();
  }
}

TEST(OptionsCodec, BuildOptionsDefaultsAndKeys) {
  OpenOptions defaults;
  defaults.surfels.target_surfels = 1000;
  v1::BuildOptions proto;
  const OpenOptions a = decode_open_options(proto, defaults);
  EXPECT_EQ(a.surfels.target_surfels, 1000u);
  proto.set_target_surfels(2000);
  const OpenOptions b = decode_open_options(proto, defaults);
  EXPECT_EQ(b.surfels.target_surfels, 2000u);
  EXPECT_NE(open_options_key(a), open_options_key(b));
  EXPECT_EQ(open_options_key(a), open_options_key(decode_open_options(v1::BuildOptions(), defaults)));
}

TEST(OptionsCodec, BouncesAreABuildOptionWithTheirOwnKey) {
  OpenOptions defaults;
  v1::BuildOptions proto;
  EXPECT_EQ(decode_open_options(proto, defaults).bounce.bounces, 1u);
  proto.set_bounces(3);
  const OpenOptions three = decode_open_options(proto, defaults);
  EXPECT_EQ(three.bounce.bounces, 3u);
  EXPECT_EQ(encode_open_options(three).bounces(), 3u);
  EXPECT_NE(open_options_key(three), open_options_key(defaults));
  proto.set_bounces(kMaxBounces + 1);
  try {
    decode_open_options(proto, defaults);
    FAIL() << "bounces out of range accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("bounces"), std::string::npos) << e.what();
  }
}

TEST(OptionsCodec, BounceSplattingIsABuildOptionWithItsOwnKey) {
  OpenOptions defaults;
  v1::BuildOptions proto;
  // Unset: the daemon's defaults.
  EXPECT_TRUE(decode_open_options(proto, defaults).bounce.splatting);
  EXPECT_EQ(decode_open_options(proto, defaults).bounce.view_solid_angle, 0.f);
  proto.set_bounce_splatting(false);
  proto.set_bounce_view_solid_angle(0.02f);
  const OpenOptions o = decode_open_options(proto, defaults);
  EXPECT_FALSE(o.bounce.splatting);
  EXPECT_EQ(o.bounce.view_solid_angle, 0.02f);
  EXPECT_FALSE(encode_open_options(o).bounce_splatting());
  EXPECT_EQ(encode_open_options(o).bounce_view_solid_angle(), 0.02f);
  EXPECT_NE(open_options_key(o), open_options_key(defaults));
  proto.set_bounce_view_solid_angle(-1.f);
  try {
    decode_open_options(proto, defaults);
    FAIL() << "negative bounce_view_solid_angle accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("bounce_view_solid_angle"), std::string::npos) << e.what();
  }
}

TEST(OptionsCodec, CoarseBounceOptionsAreBuildOptionsWithTheirOwnKey) {
  OpenOptions defaults;
  v1::BuildOptions proto;
  // Unset: the daemon's defaults.
  const OpenOptions unset = decode_open_options(proto, defaults);
  EXPECT_EQ(unset.bounce.receiver_stride, defaults.bounce.receiver_stride);
  EXPECT_EQ(unset.bounce.gather.microbuffer_resolution, defaults.bounce.gather.microbuffer_resolution);
  EXPECT_EQ(unset.bounce.gather.max_solid_angle, defaults.bounce.gather.max_solid_angle);
  // Today's full bounce, asked for explicitly.
  proto.set_bounce_receiver_stride(1);
  proto.set_bounce_microbuffer_resolution(8);
  proto.set_bounce_max_solid_angle(0.03f);
  const OpenOptions o = decode_open_options(proto, defaults);
  EXPECT_EQ(o.bounce.receiver_stride, 1u);
  EXPECT_EQ(o.bounce.gather.microbuffer_resolution, 8u);
  EXPECT_EQ(o.bounce.gather.max_solid_angle, 0.03f);
  const v1::BuildOptions back = encode_open_options(o);
  EXPECT_EQ(back.bounce_receiver_stride(), 1u);
  EXPECT_EQ(back.bounce_microbuffer_resolution(), 8u);
  EXPECT_EQ(back.bounce_max_solid_angle(), 0.03f);
  EXPECT_NE(open_options_key(o), open_options_key(defaults));
  const auto error_naming = [&](v1::BuildOptions bad) {
    try {
      decode_open_options(bad, defaults);
    } catch (const InvalidArgument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  v1::BuildOptions bad = proto;
  bad.set_bounce_receiver_stride(0);
  EXPECT_NE(error_naming(bad).find("bounce_receiver_stride"), std::string::npos) << error_naming(bad);
  bad = proto;
  bad.set_bounce_receiver_stride(65);
  EXPECT_NE(error_naming(bad).find("bounce_receiver_stride"), std::string::npos) << error_naming(bad);
  bad = proto;
  bad.set_bounce_microbuffer_resolution(2);
  EXPECT_NE(error_naming(bad).find("bounce_microbuffer_resolution"), std::string::npos) << error_naming(bad);
  bad = proto;
  bad.set_bounce_max_solid_angle(-0.1f);
  EXPECT_NE(error_naming(bad).find("bounce_max_solid_angle"), std::string::npos) << error_naming(bad);
}

TEST(OptionsCodec, SamplerAndAdaptiveSpacingAreBuildOptionsWithTheirOwnKey) {
  OpenOptions defaults;
  v1::BuildOptions proto;
  EXPECT_EQ(decode_open_options(proto, defaults).surfels.sampler, SurfelSampler::kUniform);
  proto.set_sampler("poisson");
  const OpenOptions poisson = decode_open_options(proto, defaults);
  EXPECT_EQ(poisson.surfels.sampler, SurfelSampler::kPoisson);
  EXPECT_NE(open_options_key(poisson), open_options_key(defaults));

  proto.set_spacing_camera("/World/Camera");
  proto.set_spacing_image_width(640);
  proto.set_spacing_image_height(360);
  proto.set_pixel_footprint(2.f);
  const OpenOptions adaptive = decode_open_options(proto, defaults);
  EXPECT_TRUE(adaptive.surfels.adaptive());
  EXPECT_EQ(adaptive.surfels.camera, "/World/Camera");
  EXPECT_EQ(adaptive.surfels.image_width, 640u);
  EXPECT_EQ(adaptive.surfels.image_height, 360u);
  EXPECT_EQ(adaptive.surfels.pixel_footprint, 2.f);
  EXPECT_NE(open_options_key(adaptive), open_options_key(poisson));
  // Round trip through the encoder keeps every field (and so the key).
  EXPECT_EQ(open_options_key(decode_open_options(encode_open_options(adaptive), defaults)),
            open_options_key(adaptive));

  // A camera needs the poisson sampler; an unknown sampler is refused by name.
  proto.set_sampler("uniform");
  EXPECT_THROW(decode_open_options(proto, defaults), InvalidArgument);
  proto.set_sampler("stratified");
  try {
    decode_open_options(proto, defaults);
    FAIL() << "unknown sampler accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("BuildOptions.sampler"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("stratified"), std::string::npos) << e.what();
  }
}

TEST(OptionsCodec, GlossySenderOptionsAreBuildOptionsWithTheirOwnKey) {
  const OpenOptions defaults;
  v1::BuildOptions proto;
  const OpenOptions unset = decode_open_options(proto, defaults);
  EXPECT_EQ(unset.surfels.glossy_roughness, defaults.surfels.glossy_roughness);
  EXPECT_EQ(unset.tree.glossy_resolution, defaults.tree.glossy_resolution);
  EXPECT_EQ(unset.tree.wavelet_threshold, defaults.tree.wavelet_threshold);

  proto.set_glossy_roughness(0.f);  // explicitly off, not "the default"
  const OpenOptions off = decode_open_options(proto, defaults);
  EXPECT_EQ(off.surfels.glossy_roughness, 0.f);
  EXPECT_NE(open_options_key(off), open_options_key(unset));

  proto.set_glossy_roughness(0.5f);
  proto.set_glossy_resolution(32);
  proto.set_wavelet_threshold(0.1f);
  const OpenOptions set = decode_open_options(proto, defaults);
  EXPECT_EQ(set.surfels.glossy_roughness, 0.5f);
  EXPECT_EQ(set.tree.glossy_resolution, 32u);
  EXPECT_EQ(set.tree.wavelet_threshold, 0.1f);
  EXPECT_EQ(open_options_key(decode_open_options(encode_open_options(set), defaults)), open_options_key(set));

  proto.set_glossy_resolution(12);
  EXPECT_THROW(decode_open_options(proto, defaults), InvalidArgument);
  proto.set_glossy_resolution(16);
  proto.set_wavelet_threshold(-1.f);
  EXPECT_THROW(decode_open_options(proto, defaults), InvalidArgument);
}

TEST(OptionsCodec, LeafFormatIsABuildOptionWithItsOwnKey) {
  const OpenOptions defaults;
  v1::BuildOptions proto;
  EXPECT_EQ(decode_open_options(proto, defaults).tree.leaf_format, storage::LeafFormat::kRelative);
  proto.set_leaf_format("half");
  const OpenOptions half = decode_open_options(proto, defaults);
  EXPECT_EQ(half.tree.leaf_format, storage::LeafFormat::kHalf);
  EXPECT_NE(open_options_key(half), open_options_key(defaults));
  EXPECT_EQ(decode_open_options(encode_open_options(half), defaults).tree.leaf_format, storage::LeafFormat::kHalf);
  proto.set_leaf_format("A");
  try {
    decode_open_options(proto, defaults);
    FAIL() << "accepted leaf_format A";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("BuildOptions.leaf_format"), std::string::npos) << e.what();
  }
}

TEST(OptionsCodec, FogOptionsAreBuildOptionsWithTheirOwnKey) {
  const OpenOptions defaults;
  v1::BuildOptions proto;
  const OpenOptions unset = decode_open_options(proto, defaults);
  EXPECT_EQ(unset.fog.extinction_per_density, defaults.fog.extinction_per_density);
  EXPECT_EQ(unset.fog.albedo, defaults.fog.albedo);

  proto.mutable_fog()->set_albedo(0.f);  // absorbing, not "the default"
  proto.mutable_fog()->set_extinction_per_density(3.f);
  const OpenOptions set = decode_open_options(proto, defaults);
  EXPECT_EQ(set.fog.albedo, Imath::C3f(0.f));
  EXPECT_EQ(set.fog.extinction_per_density, 3.f);
  EXPECT_EQ(set.fog.step_voxels, defaults.fog.step_voxels);  // 0 in the request: the default
  EXPECT_NE(open_options_key(set), open_options_key(unset));
  EXPECT_EQ(open_options_key(decode_open_options(encode_open_options(set), defaults)), open_options_key(set));

  proto.mutable_fog()->set_albedo(2.f);
  try {
    decode_open_options(proto, defaults);
    FAIL() << "albedo 2 accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("BuildOptions.fog"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace pbgi::service
