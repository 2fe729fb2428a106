// `pbgi status`: what a running pbgid holds: open scenes (with their memory
// and idle time), opens in flight, the page cache, memory and request
// counters. Text, or the GetStatusResponse as JSON with --json.
#include "client/cli/command.h"
#include "client/cli/connection_flags.h"
#include "client/cli/scene_warnings.h"
#include "client/lib/pbgi_client.h"

#include <google/protobuf/util/json_util.h>

#include <cstdio>

namespace pbgi::cli {
namespace {

struct StatusArgs {
  ConnectionArgs connection;
  bool json = false;
};

std::string mib(uint64_t bytes) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f MiB", double(bytes) / (1 << 20));
  return text;
}

int run_status(const StatusArgs& args) {
  client::ClientOptions options = args.connection.client_options();
  options.call_deadline = std::chrono::seconds(10);
  client::PbgiClient client(args.connection.server, options);
  const v1::GetStatusResponse s = client.status();
  if (args.json) {
    std::string json;
    google::protobuf::util::JsonPrintOptions print;
    print.always_print_primitive_fields = true;
    (void)google::protobuf::util::MessageToJsonString(s, &json, print);
    std::printf("%s\n", json.c_str());
    return 0;
  }
  std::printf("daemon    %s, version %s, up %.0f s, %s resident\n", client.address().c_str(),
              s.version().c_str(), s.uptime_seconds(), mib(s.rss_bytes()).c_str());
  const v1::CacheStatus& c = s.cache();
  const uint64_t lookups = c.hits() + c.misses();
  std::printf(
      "cache     %s of %s held (pinned beyond it %s, at most %s), %llu hits, %llu misses (%.1f%% hits), %llu "
      "evictions, "
      "%s read\n",
      mib(c.bytes_held()).c_str(), mib(c.budget_bytes()).c_str(), mib(c.bytes_pinned()).c_str(),
      mib(c.bytes_pinned_peak()).c_str(), static_cast<unsigned long long>(c.hits()),
      static_cast<unsigned long long>(c.misses()), lookups ? 100.0 * double(c.hits()) / double(lookups) : 0.0,
      static_cast<unsigned long long>(c.evictions()), mib(c.bytes_read()).c_str());
  if (s.has_memory()) {
    const v1::MemoryStatus& m = s.memory();
    std::printf(
        "memory    budget %s: requests %s, scenes %s, reading %s, builds %s, page cache %s "
        "(floor %s); %llu refused\n",
        mib(m.budget_bytes()).c_str(), mib(m.request_reserve_bytes()).c_str(), mib(m.scenes_bytes()).c_str(),
        mib(m.reading_bytes()).c_str(), mib(m.builds_bytes()).c_str(), mib(c.budget_bytes()).c_str(),
        mib(m.page_cache_floor_bytes()).c_str(), static_cast<unsigned long long>(m.refusals()));
  }
  const v1::RequestStatus& r = s.requests();
  std::printf("requests  %u running (max %u), %u queued (max %u), %llu done, %llu refused\n",
              r.in_flight(), r.max_in_flight(), r.queued(), r.max_queued(),
              static_cast<unsigned long long>(r.completed()),
              static_cast<unsigned long long>(r.rejected()));
  std::printf("scenes    %d open%s\n", s.scenes_size(),
              s.scene_memory_budget_bytes()
                  ? (", budget " + mib(s.scene_memory_budget_bytes())).c_str()
                  : "");
  for (const v1::SceneStatus& scene : s.scenes()) {
    const v1::SceneInfo& i = scene.info();
    std::printf("  %s  %s\n      %llu triangles, %llu surfels, %u pages, ~%s, %llu requests, "
                "idle %.0f s\n",
                i.scene_id().c_str(), i.scene_path().c_str(),
                static_cast<unsigned long long>(i.triangle_count()),
                static_cast<unsigned long long>(i.surfel_count()), i.page_count(),
                mib(scene.memory_bytes()).c_str(),
                static_cast<unsigned long long>(scene.requests()), scene.idle_seconds());
    print_scene_warnings(i, stdout, "      ");
  }
  for (const v1::OpenStatus& o : s.opening()) {
    std::printf("  opening %s: %s %.0f%%\n", o.scene_path().c_str(), o.stage().c_str(),
                100.f * o.fraction());
  }
  return 0;
}

const CommandRegistrar kRegistrar{"status", [](CLI::App& app, int* exit_code) {
  auto args = std::make_shared<StatusArgs>();
  CLI::App* cmd = app.add_subcommand("status", "scenes, cache and memory of a running pbgid");
  args->connection.add_to(cmd);
  cmd->add_flag("--json", args->json, "the GetStatus response as JSON");
  cmd->callback([args, exit_code] { *exit_code = run_status(*args); });
}};

}  // namespace
}  // namespace pbgi::cli
