// pbgid's configuration: TOML round trip, unknown keys and wrong types
// refused with the key's name, and the precedence flags > env > file.
#include "server/daemon/daemon_command_line.h"
#include "server/daemon/daemon_options.h"

#include "common/errors.h"
#include "tests/server/service/temp_dir.h"
#include "tests/support/perturbed_option.h"

#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>

namespace pbgi::daemon {
namespace {

Environment fake_env(std::map<std::string, std::string> vars) {
  auto shared = std::make_shared<std::map<std::string, std::string>>(std::move(vars));
  return [shared](const char* name) -> const char* {
    auto it = shared->find(name);
    return it == shared->end() ? nullptr : it->second.c_str();
  };
}

std::string error_of(const std::string& toml) {
  try {
    parse_daemon_config(toml, "test.toml");
  } catch (const InvalidArgument& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted:\n" << toml;
  return "";
}

DaemonOptions non_default_options() {
  DaemonOptions o;
  o.listen = "127.0.0.1:0";
  o.scene_roots = {"/data/scenes", "/other scenes"};
  o.cache_dir = "/var/cache/pbgi";
  o.memory_budget = "512MiB";
  o.threads = 3;
  o.log_level = "debug";
  o.python = "/opt/py/bin/python3";
  o.preload = {"cornell.usda"};
  o.allow_insecure_remote = true;
  o.shutdown_grace_seconds = 2.5;
  o.max_message_size = "32MiB";
  o.service.defaults.render.gather.microbuffer_resolution = 16;
  o.service.defaults.render.gather.max_solid_angle = 0.03f;
  o.service.defaults.render.gather.ao_max_distance = 0.7f;
  o.service.defaults.render.light_samples = 5;
  o.service.defaults.render.pixel_samples = 4;
  o.service.defaults.render.gather.method = GatherMethod::kFpbgi;
  o.service.defaults.render.gather.clusters = 64;
  o.service.defaults.render.gather.epsilon = 0.02f;
  o.service.defaults.render.gather.hdr_refine = 0.5f;
  o.service.defaults.render.gather.glossy_max_resolution = 64;
  o.service.defaults.render.gather.glossy_importance = 0.03f;
  o.service.defaults.render.gather.glossy_radiance_weight = 0.25f;
  o.service.defaults.render.gather.bent_normal = true;
  o.service.defaults.open.surfels.spacing = 0.013f;
  o.service.defaults.open.surfels.sampler = SurfelSampler::kPoisson;
  o.service.defaults.open.surfels.camera = "/World/Camera";
  o.service.defaults.open.surfels.image_width = 640;
  o.service.defaults.open.surfels.image_height = 360;
  o.service.defaults.open.surfels.pixel_footprint = 1.5f;
  o.service.defaults.open.surfels.glossy_roughness = 0.2f;
  o.service.defaults.open.tree.glossy_resolution = 32;
  o.service.defaults.open.tree.wavelet_threshold = 0.05f;
  o.service.defaults.open.surfels.target_surfels = 12345;
  o.service.defaults.open.surfels.light_samples = 9;
  o.service.defaults.open.surfels.seed = 42;
  o.service.defaults.open.tree.page_size = 32768;
  o.service.defaults.open.tree.leaf_size = 8;
  o.service.defaults.open.tree.leaf_format = storage::LeafFormat::kHalf;
  o.service.defaults.open.tree.payload_codec = tree::PayloadCodecOption::kQuantizedSh;
  o.service.defaults.open.tree.lut_entries = 1000;
  o.service.defaults.open.tree.lut_sample_fraction = 0.05;
  o.service.defaults.open.bounce.bounces = 2;
  o.service.defaults.open.bounce.splatting = false;
  o.service.defaults.open.bounce.view_solid_angle = 0.02f;
  o.service.defaults.open.bounce.receiver_stride = 4;
  o.service.defaults.open.bounce.gather.microbuffer_resolution = 16;
  o.service.defaults.open.bounce.gather.max_solid_angle = 0.05f;
  o.service.defaults.open.fog.extinction_per_density = 2.5f;
  o.service.defaults.open.fog.albedo = Imath::C3f(0.3f);
  o.service.defaults.open.fog.step_voxels = 0.25f;
  o.service.defaults.open.fog.light_samples = 2;
  o.service.defaults.open.fog.max_block_voxels = 8;
  o.service.limits.max_receivers = 1000;
  o.service.limits.max_image_side = 4096;
  o.service.limits.max_tile_pixels = 4096;
  o.service.limits.max_tiles_per_call = 17;
  o.service.limits.max_in_flight = 3;
  o.service.limits.max_queued = 5;
  o.service.limits.max_surfels = 1'000'000;
  o.scene_memory_budget = "6GiB";
  o.page_cache_limit = "96MiB";
  o.staging_quota = "100GiB";
  o.log_format = "json";
  o.metrics_listen = "127.0.0.1:9464";
  o.tls_cert = "/etc/pbgi/server.crt";
  o.tls_key = "/etc/pbgi/server.key";
  o.tls_client_ca = "/etc/pbgi/clients.crt";
  o.auth_token_file = "/etc/pbgi/token";
  return o;
}

TEST(DaemonOptions, TomlRoundTrip) {
  const DaemonOptions original = non_default_options();
  const std::string text = to_toml(original);
  const DaemonOptions back = parse_daemon_config(text, "round-trip");
  EXPECT_TRUE(back == original) << text;
  EXPECT_EQ(to_toml(back), text);
  // Floats print as written, not as their binary expansion.
  EXPECT_NE(text.find("max_solid_angle = 0.03\n"), std::string::npos) << text;
  // And the defaults round-trip too.
  EXPECT_TRUE(parse_daemon_config(to_toml(DaemonOptions()), "defaults") == DaemonOptions());
}

// Each stage option changed alone: the options differ, and the TOML
// round trip keeps the change (the tables drive both, key by key).
template <class Table, class Section>
void expect_each_option_in_toml(const Table& table, Section section) {
  int checked = 0;
  options::for_each_field(table, [&](const auto& probe) {
    DaemonOptions changed;
    options::for_each_value(
        table,
        [&](const auto& f, auto& values) {
          if constexpr (std::is_same_v<std::remove_cvref_t<decltype(f)>, std::remove_cvref_t<decltype(probe)>>) {
            if (f.name == probe.name && f.get == probe.get) f.set(values, testing::perturbed(f.get(values)));
          }
        },
        section(changed));
    EXPECT_FALSE(changed == DaemonOptions()) << probe.name << " is not compared";
    EXPECT_TRUE(parse_daemon_config(to_toml(changed), "round-trip") == changed) << probe.name;
    ++checked;
  });
  EXPECT_GT(checked, 4);
}

TEST(DaemonOptions, EveryStageOptionIsComparedAndRoundTrips) {
  expect_each_option_in_toml(kRenderOptionTable, [](DaemonOptions& o) -> auto& { return o.service.defaults.render; });
  expect_each_option_in_toml(kOpenOptionTable, [](DaemonOptions& o) -> auto& { return o.service.defaults.open; });
  expect_each_option_in_toml(service::kRequestLimitsTable, [](DaemonOptions& o) -> auto& { return o.service.limits; });
}

TEST(DaemonOptions, TheExampleConfigParsesToTheDefaults) {
  const DaemonOptions example =
      load_daemon_config(std::string(PBGI_TEST_SOURCE_DIR) + "/config/pbgid.toml");
  DaemonOptions expected;
  expected.scene_roots = {"scenes"};
  EXPECT_TRUE(example == expected) << "config/pbgid.toml documents the defaults:\n"
                                   << to_toml(example);
}

TEST(DaemonOptions, SecretTokenIsNeverPrinted) {
  DaemonOptions o;
  apply_environment(o, fake_env({{"PBGI_AUTH_TOKEN", "hunter2"},
                                 {"PBGI_METRICS_LISTEN", "127.0.0.1:0"}}));
  EXPECT_EQ(o.auth_token, "hunter2");
  EXPECT_EQ(o.metrics_listen, "127.0.0.1:0");
  const std::string text = to_toml(o);
  EXPECT_EQ(text.find("hunter2"), std::string::npos) << text;
  EXPECT_NE(text.find("PBGI_AUTH_TOKEN"), std::string::npos) << text;
}

TEST(DaemonOptions, AbsentKeysKeepTheBase) {
  DaemonOptions base = non_default_options();
  const DaemonOptions o = parse_daemon_config("threads = 7\n[gather]\nlight_samples = 2\n", "t", base);
  EXPECT_EQ(o.threads, 7u);
  EXPECT_EQ(o.service.defaults.render.light_samples, 2u);
  EXPECT_EQ(o.cache_dir, base.cache_dir);
  EXPECT_EQ(o.service.defaults.render.gather.microbuffer_resolution, 16u);
}

TEST(DaemonOptions, UnknownKeysAreRefusedByName) {
  EXPECT_NE(error_of("listn = \"unix:/tmp/x\"\n").find("'listn'"), std::string::npos);
  EXPECT_NE(error_of("[gather]\nmb_res = 8\n").find("'gather.mb_res'"), std::string::npos);
  EXPECT_NE(error_of("[limits]\nmax_tiles = 1\n").find("'limits.max_tiles'"), std::string::npos);
  EXPECT_NE(error_of("[render]\nx = 1\n").find("'render'"), std::string::npos);
  EXPECT_NE(error_of("listn = 1\n").find("test.toml"), std::string::npos) << "names the file";
}

TEST(DaemonOptions, WrongTypesAndRangesAreRefusedByName) {
  EXPECT_NE(error_of("threads = \"four\"\n").find("'threads'"), std::string::npos);
  EXPECT_NE(error_of("threads = -1\n").find("'threads'"), std::string::npos);
  EXPECT_NE(error_of("scene_roots = \"/a\"\n").find("'scene_roots'"), std::string::npos);
  EXPECT_NE(error_of("gather = 3\n").find("'gather'"), std::string::npos);
  EXPECT_NE(error_of("[gather]\nmicrobuffer_resolution = 5000000000\n").find("microbuffer_resolution"),
            std::string::npos);
  EXPECT_NE(error_of("threads = \n").find("line 1"), std::string::npos) << "parse errors have a line";
  EXPECT_NE(error_of("[gather]\nmethod = \"fast\"\n").find("gather.method"), std::string::npos);
  EXPECT_NE(error_of("[build]\npayload_codec = \"zip\"\n").find("payload_codec"), std::string::npos);
  EXPECT_NE(error_of("[build]\nsampler = \"blue\"\n").find("build.sampler"), std::string::npos);
  EXPECT_NE(error_of("[fog]\nalbedo = 2.0\n").find("fog.albedo"), std::string::npos);
  EXPECT_NE(error_of("[fog]\nmax_block_voxels = 6\n").find("fog.max_block_voxels"), std::string::npos);
  EXPECT_NE(error_of("[fog]\ndensity = 1.0\n").find("'fog.density'"), std::string::npos);
}

TEST(DaemonOptions, ValidateChecksValuesByName) {
  DaemonOptions o;
  o.memory_budget = "lots";
  EXPECT_THROW(o.validate(), InvalidArgument);
  o = DaemonOptions();
  o.log_level = "chatty";
  EXPECT_THROW(o.validate(), InvalidArgument);
  o = DaemonOptions();
  o.listen = "0.0.0.0:5000";
  EXPECT_THROW(o.validate(), InvalidArgument) << "remote plaintext needs allow_insecure_remote";
  o.allow_insecure_remote = true;
  EXPECT_NO_THROW(o.validate());
  o = DaemonOptions();
  o.service.defaults.render.gather.microbuffer_resolution = 1;
  EXPECT_THROW(o.validate(), InvalidArgument);
  // The bounce defaults too, before any scene is opened with them.
  o = DaemonOptions();
  o.service.defaults.open.bounce.receiver_stride = 0;
  try {
    o.validate();
    ADD_FAILURE() << "bounce_receiver_stride = 0 accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("bounce_receiver_stride"), std::string::npos) << e.what();
  }
  o = DaemonOptions();
  o.staging_quota = "a lot";
  EXPECT_THROW(o.validate(), InvalidArgument);
  EXPECT_NO_THROW(DaemonOptions().validate());
  EXPECT_EQ(DaemonOptions().memory_budget_bytes(), 2ull << 30);
}

TEST(DaemonOptions, DefaultListenIsInTheCacheDir) {
  DaemonOptions o;
  o.cache_dir = "/var/cache/pbgi";
  EXPECT_EQ(o.effective_listen(), "unix:/var/cache/pbgi/pbgid.sock");
  o.listen = "127.0.0.1:1";
  EXPECT_EQ(o.effective_listen(), "127.0.0.1:1");
}

TEST(DaemonOptions, EnvironmentOverridesDefaults) {
  DaemonOptions o;
  apply_environment(o, fake_env({{"PBGI_SCENE_ROOTS", "/a::/b"},
                                 {"PBGI_MEMORY_BUDGET", "1G"},
                                 {"PBGI_THREADS", "2"},
                                 {"PBGI_PYTHON", "/py"},
                                 {"PBGI_LOG_LEVEL", ""}}));
  EXPECT_EQ(o.scene_roots, (std::vector<std::string>{"/a", "/b"}));
  EXPECT_EQ(o.memory_budget, "1G");
  EXPECT_EQ(o.threads, 2u);
  EXPECT_EQ(o.python, "/py");
  EXPECT_EQ(o.log_level, "info") << "empty variables are ignored";
  EXPECT_THROW(apply_environment(o, fake_env({{"PBGI_THREADS", "two"}})), InvalidArgument);
  EXPECT_THROW(apply_environment(o, fake_env({{"PBGI_MEMORY_BUDGET", "x"}})), InvalidArgument);
}

TEST(DaemonOptions, AnEmptyAuthTokenIsRefusedNotAuthenticationOff) {
  for (const char* variable : {"PBGI_AUTH_TOKEN", "PBGI_AUTH_TOKEN_FILE"}) {
    DaemonOptions o;
    try {
      apply_environment(o, fake_env({{variable, ""}}));
      ADD_FAILURE() << variable << "= accepted: the daemon would run without authentication";
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(variable), std::string::npos) << e.what();
    }
  }
}

TEST(DaemonOptions, MetricsOffLoopbackNeedATokenOrExplicitPermission) {
  DaemonOptions o;
  o.metrics_listen = "127.0.0.1:0";
  EXPECT_NO_THROW(o.validate());
  o.metrics_listen = "0.0.0.0:9100";
  EXPECT_THROW(o.validate(), InvalidArgument) << "metrics open to the network without a token";
  o.auth_token = "t";
  EXPECT_NO_THROW(o.validate());
  o.auth_token.clear();
  o.allow_insecure_remote = true;
  EXPECT_NO_THROW(o.validate());
}

TEST(DaemonOptions, AMissingConfigFileSaysWhy) {
  testing::TempDir tmp;
  try {
    load_daemon_config(tmp.path() / "missing.toml");
    ADD_FAILURE() << "a missing config file was read";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("No such file"), std::string::npos) << e.what();
  }
}

struct ParsedRun {
  CommandLine result;
  std::string out, err;
};
ParsedRun run(std::vector<std::string> args, const Environment& env) {
  args.insert(args.begin(), "pbgid");
  std::vector<const char*> argv;
  for (const auto& a : args) argv.push_back(a.c_str());
  std::ostringstream out, err;
  ParsedRun r;
  r.result = parse_command_line(static_cast<int>(argv.size()), argv.data(), env, out, err);
  r.out = out.str();
  r.err = err.str();
  return r;
}

TEST(DaemonCommandLine, FlagsWinOverEnvironmentOverFile) {
  testing::TempDir tmp;
  const std::string config = (tmp.path() / "pbgid.toml").string();
  std::ofstream(config) << "cache_dir = \"/from/file\"\nthreads = 1\nlog_level = \"warn\"\n"
                           "scene_roots = [\"/file/scenes\"]\n";
  const Environment env = fake_env({{"PBGI_CACHE_DIR", "/from/env"}, {"PBGI_THREADS", "2"}});

  ParsedRun r = run({"--config", config, "--threads", "3"}, env);
  ASSERT_TRUE(r.result.options) << r.err;
  EXPECT_EQ(r.result.options->threads, 3u);                // flag
  EXPECT_EQ(r.result.options->cache_dir, "/from/env");     // env over file
  EXPECT_EQ(r.result.options->log_level, "warn");          // file over default
  EXPECT_EQ(r.result.options->scene_roots, (std::vector<std::string>{"/file/scenes"}));

  r = run({"--scene-root", "/x", "--scene-root", "/y"},
          fake_env({{"PBGI_CONFIG", config}}));
  ASSERT_TRUE(r.result.options) << r.err;
  EXPECT_EQ(r.result.options->scene_roots, (std::vector<std::string>{"/x", "/y"}));
  EXPECT_EQ(r.result.options->cache_dir, "/from/file") << "PBGI_CONFIG names the file";
}

TEST(DaemonCommandLine, PrintConfigPrintsEffectiveToml) {
  ParsedRun r = run({"--print-config", "--memory-budget", "3GiB", "--listen", "unix:/tmp/p.sock",
                     "--max-surfels", "5000000", "--staging-quota", "8GiB"},
              fake_env({}));
  EXPECT_FALSE(r.result.options);
  EXPECT_EQ(r.result.exit_code, 0);
  const DaemonOptions printed = parse_daemon_config(r.out, "printed");
  EXPECT_EQ(printed.memory_budget, "3GiB");
  EXPECT_EQ(printed.listen, "unix:/tmp/p.sock");
  EXPECT_EQ(printed.service.limits.max_surfels, 5'000'000u);
  EXPECT_EQ(printed.staging_quota, "8GiB");
  EXPECT_EQ(printed.staging_quota_bytes(), 8ull << 30);
}

TEST(DaemonCommandLine, ConfigErrorsExitWithMessage) {
  testing::TempDir tmp;
  const std::string config = (tmp.path() / "bad.toml").string();
  std::ofstream(config) << "[gather]\nbogus = 1\n";
  ParsedRun r = run({"--config", config}, fake_env({}));
  EXPECT_FALSE(r.result.options);
  EXPECT_EQ(r.result.exit_code, 2);
  EXPECT_NE(r.err.find("gather.bogus"), std::string::npos) << r.err;

  r = run({"--memory-budget", "2XB"}, fake_env({}));
  EXPECT_EQ(r.result.exit_code, 2);
  EXPECT_NE(r.err.find("memory_budget"), std::string::npos) << r.err;

  r = run({"--listen", "0.0.0.0:1"}, fake_env({}));
  EXPECT_EQ(r.result.exit_code, 2);
  r = run({"--listen", "0.0.0.0:1", "--allow-insecure-remote"}, fake_env({}));
  EXPECT_TRUE(r.result.options) << r.err;

  r = run({"--no-such-flag"}, fake_env({}));
  EXPECT_FALSE(r.result.options);
  EXPECT_NE(r.result.exit_code, 0);

  r = run({"--config", (tmp.path() / "missing.toml").string()}, fake_env({}));
  EXPECT_EQ(r.result.exit_code, 2);
  EXPECT_NE(r.err.find("missing.toml"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace pbgi::daemon
