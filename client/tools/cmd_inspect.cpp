// `pbgi inspect CACHE_DIR`: what a page set holds and how well it packs:
// manifest, node/leaf/surfel counts, bytes per surfel and per node, depth
// statistics, page count and fill. The walk reads and verifies every page
// (checksums included), so a clean run also means an intact page set.
#include "client/cli/command.h"
#include "client/cli/json_text.h"
#include "client/cli/tool_commands.h"
#include "storage/cache/page_cache.h"
#include "storage/format/format_version.h"
#include "storage/pages/manifest_file.h"
#include "storage/pages/page_set.h"
#include "storage/pages/page_set_inspection.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <memory>

namespace pbgi::tools {
namespace {

using cli::CommandRegistrar;
using cli::json_number;
using cli::json_string;
using cli::tool_command_description;

struct InspectArgs {
  std::string dir;
  bool json = false;
  bool no_walk = false;
  uint64_t cache_mb = 256;
};

std::string json_number(double v) { return cli::json_number(v, 6); }

double per(uint64_t a, uint64_t b) { return b ? double(a) / double(b) : 0.0; }

// The manifest version the writer used (storage/pages/manifest_file.h).
uint32_t manifest_version(const storage::Manifest& m) { return storage::manifest_format_of(m); }

void print_json(const std::string& dir, const storage::Manifest& m,
                const storage::PageSetInspection& r, const storage::CacheCounters& c) {
  const auto& s = m.stats;
  std::string out = "{\n";
  out += fmt::format("  \"dir\": {},\n  \"build_key\": {},\n", json_string(dir), json_string(m.build_key));
  out += fmt::format("  \"format\": {{\"manifest\": {}, \"page\": {}, \"page_set\": {}}},\n",
                     manifest_version(m), m.page_format, storage::kPageSetFormatVersion);
  out += fmt::format("  \"glossy\": {{\"resolution\": {}, \"wavelet_threshold\": {}}},\n", m.glossy_resolution,
                     json_number(m.options.wavelet_threshold));
  out += fmt::format("  \"codec\": {{\"id\": {}, \"name\": {}}},\n", m.codec, json_string(r.codec_name));
  out += fmt::format(
      "  \"options\": {{\"leaf_size\": {}, \"leaf_format\": {}, \"page_size\": {}, \"payload_codec\": {}, "
      "\"lut_entries\": {}, \"lut_sample_fraction\": {}}},\n  \"node_payloads\": {},\n",
      m.options.leaf_size, json_string(storage::to_string(m.options.leaf_format)), m.options.page_size,
      json_string(tree::to_string(m.options.payload_codec)),
      m.options.lut_entries, m.options.lut_sample_fraction, m.node_payloads ? "true" : "false");
  out += fmt::format(
      "  \"stats\": {{\"surfels\": {}, \"nodes\": {}, \"leaves\": {}, \"pages\": {}, \"max_depth\": {}, "
      "\"file_bytes\": {}}},\n",
      s.surfel_count, s.node_count, s.leaf_count, s.page_count, s.max_depth, s.file_bytes);
  out += fmt::format("  \"root\": {{\"page\": {}, \"index\": {}}},\n", m.root.page, m.root.index);
  {
    const tree::RegionGrid& g = m.regions;
    std::string roots;
    for (const tree::RegionRoot& root : m.region_roots) {
      roots += fmt::format(R"({}{{"region": {}, "page": {}, "index": {}}})", roots.empty() ? "" : ", ", root.region,
                           root.root.page, root.root.index);
    }
    out += fmt::format(
        "  \"air_regions\": {{\"count\": {}, \"dims\": [{}, {}, {}], \"voxel\": {}, \"runs\": {}, "
        "\"roots\": [{}]}},\n",
        g.region_count(), g.dims().x, g.dims().y, g.dims().z, json_number(g.voxel()), g.unique_runs(), roots);
  }
  out += fmt::format(
      "  \"bytes\": {{\"per_surfel\": {}, \"per_node\": {}, \"topology_per_node\": {}, "
      "\"payload_per_node\": {}, \"surfel_record\": {}, \"packed_sections\": {}, \"decoded_node\": {}, "
      "\"decoded_surfel\": {}}},\n",
      json_number(per(s.file_bytes, s.surfel_count)), json_number(per(s.file_bytes, s.node_count)),
      json_number(r.topology_bytes_per_node), r.payload_bytes_per_node, r.surfel_record_bytes,
      r.packed_sections ? "true" : "false", sizeof(tree::Node), sizeof(Surfel));
  out += fmt::format(
      "  \"pages\": {{\"count\": {}, \"page_bytes\": {}, \"padding_bytes\": {}, \"fill_mean\": {}, "
      "\"fill_min\": {}, \"fill_max\": {}}}",
      s.page_count, r.page_bytes_total, r.padding_bytes, json_number(r.fill_mean),
      json_number(r.fill_min), json_number(r.fill_max));
  if (r.walked) {
    out += fmt::format(
        ",\n  \"walk\": {{\"nodes\": {}, \"leaves\": {}, \"surfels\": {}, \"pages_reached\": {}, "
        "\"leaf_depth\": {{\"min\": {}, \"mean\": {}, \"max\": {}}}, \"leaf_surfels_mean\": {}, "
        "\"path_pages\": {{\"mean\": {}, \"max\": {}}}, \"consistent\": {}, \"bytes_read\": {}}}",
        r.nodes, r.leaves, r.surfels, r.pages_reached, r.leaf_depth_min, json_number(r.leaf_depth_mean),
        r.leaf_depth_max, json_number(r.leaf_surfels_mean), json_number(r.path_pages_mean),
        r.path_pages_max, r.consistent ? "true" : "false", c.bytes_read);
  }
  out += "\n}\n";
  std::fputs(out.c_str(), stdout);
}

void print_text(const std::string& dir, const storage::Manifest& m, const storage::PageSetInspection& r) {
  const auto& s = m.stats;
  fmt::print("page set      {}\n", dir);
  fmt::print("build key     {}\n", m.build_key);
  fmt::print("format        manifest v{}, pages v{}, codec {} ({})\n", manifest_version(m),
             m.page_format, m.codec, r.codec_name);
  fmt::print("options       leaf_size {}, leaf_format {}, page_size {}, payload_codec {} (lut {} entries, sample {})\n",
             m.options.leaf_size, storage::to_string(m.options.leaf_format), m.options.page_size,
             tree::to_string(m.options.payload_codec),
             m.options.lut_entries, m.options.lut_sample_fraction);
  fmt::print("payloads      {}\n", m.node_payloads ? "stored for every node" : "derived when a page loads");
  if (m.glossy_resolution) {
    fmt::print("glossy        wavelet cube maps {}^2 per face, threshold {} (storage/codecs/glossy_pages.h)\n",
               m.glossy_resolution, m.options.wavelet_threshold);
  } else {
    fmt::print("glossy        none\n");
  }
  fmt::print("surfels       {}\n", s.surfel_count);
  fmt::print("nodes         {} ({} leaves, {} internal)\n", s.node_count, s.leaf_count,
             s.node_count - s.leaf_count);
  fmt::print("root          page {}, index {}\n", m.root.page, m.root.index);
  if (m.region_roots.empty()) {
    fmt::print("air regions   one (the tree keeps none apart)\n");
  } else {
    const tree::RegionGrid& g = m.regions;
    fmt::print("air regions   {} on a {}x{}x{} grid of {} voxels ({} runs); subtrees of {} of them:", g.region_count(),
               g.dims().x, g.dims().y, g.dims().z, g.voxel(), g.unique_runs(), m.region_roots.size());
    for (const tree::RegionRoot& root : m.region_roots) fmt::print(" {} (page {})", root.region, root.root.page);
    fmt::print("\n");
  }
  fmt::print("file          {} bytes ({:.2f} MiB), {:.1f} bytes/surfel, {:.1f} bytes/node\n", s.file_bytes,
             s.file_bytes / 1048576.0, per(s.file_bytes, s.surfel_count), per(s.file_bytes, s.node_count));
  const char* packing = r.packed_sections ? " before packing (leaf frames, surfel records and link payloads are "
                                            "bit-packed per page)"
                                          : "";
  fmt::print("records       node {} B (topology {} + payload {}), surfel {} B{}; decoded node {} B, surfel {} B\n",
             r.topology_bytes_per_node + double(r.payload_bytes_per_node), r.topology_bytes_per_node,
             r.payload_bytes_per_node, r.surfel_record_bytes, packing, sizeof(tree::Node), sizeof(Surfel));
  fmt::print("pages         {} pages, fill mean {:.1f}% (min {:.1f}%, max {:.1f}%), padding {} bytes\n",
             s.page_count, 100 * r.fill_mean, 100 * r.fill_min, 100 * r.fill_max, r.padding_bytes);
  if (!r.walked) {
    fmt::print("depth         max {} (manifest; run without --no-walk for more)\n", s.max_depth);
    return;
  }
  fmt::print("leaf depth    min {}, mean {:.2f}, max {}\n", r.leaf_depth_min, r.leaf_depth_mean,
             r.leaf_depth_max);
  fmt::print("leaf size     mean {:.2f} surfels\n", r.leaf_surfels_mean);
  fmt::print("path pages    mean {:.2f}, max {} (pages from the root to a leaf)\n", r.path_pages_mean,
             r.path_pages_max);
  fmt::print("walk          {} nodes, {} leaves, {} surfels, {}/{} pages verified: {}\n", r.nodes, r.leaves,
             r.surfels, r.pages_reached, s.page_count,
             r.consistent ? "consistent with the manifest" : "INCONSISTENT with the manifest");
}

int run(const InspectArgs& args) {
  auto cache = std::make_shared<storage::PageCache>(args.cache_mb << 20);
  storage::PageSetReader reader(args.dir, cache);
  const storage::PageSetInspection r = storage::inspect_page_set(reader, !args.no_walk);
  if (args.json) {
    print_json(args.dir, reader.manifest(), r, cache->counters());
  } else {
    print_text(args.dir, reader.manifest(), r);
  }
  return r.consistent ? 0 : 2;
}

const CommandRegistrar kRegistrar("inspect", [](CLI::App& app, int* exit_code) {
  auto args = std::make_shared<InspectArgs>();
  CLI::App* cmd = app.add_subcommand("inspect", tool_command_description("inspect"));
  cmd->add_option("dir", args->dir, "Page set directory (holds manifest.pbgm and pages.pbgp)")
      ->required();
  cmd->add_flag("--json", args->json, "Machine-readable output");
  cmd->add_flag("--no-walk", args->no_walk, "Only read the manifest (skip reading every page)");
  cmd->add_option("--cache-mb", args->cache_mb, "Page cache budget for the walk, MiB")
      ->capture_default_str();
  cmd->callback([args, exit_code] { *exit_code = run(*args); });
});

}  // namespace
}  // namespace pbgi::tools
