#include "storage/pages/page_set_inspection.h"

#include "storage/codecs/payload_codec.h"
#include "storage/tree/page_records.h"
#include "storage/tree/payload_rounding.h"

#include <algorithm>
#include <limits>
#include <vector>

namespace pbgi::storage {

PageSetInspection inspect_page_set(const PageSetReader& reader, bool walk) {
  const Manifest& m = reader.manifest();
  PageSetInspection r;
  const auto codec = make_payload_codec(m.codec, m.codec_state, reader.directory().string());
  r.codec_name = codec->name();
  r.node_payloads = m.node_payloads;
  r.packed_sections = page_format_has_compact_frame(m.page_format);
  r.topology_bytes_per_node = r.packed_sections ? 0.5 : double(kShapeBytes);
  r.payload_bytes_per_node = m.node_payloads ? codec->bytes_per_node() : 0;
  r.surfel_record_bytes =
      surfel_record_bytes(surfel_records_of(m.options.leaf_format, page_format_has_compact_records(m.page_format)));
  r.leaf_record_bytes = r.packed_sections ? 0 : kLeafRecordBytes;  // 0: a bit-packed leaf section
  r.link_record_bytes = r.packed_sections ? kCompactLinkRecordBytes : kLinkRecordBytes;
  r.link_payload_bytes = m.node_payloads || r.packed_sections         ? 0
                         : page_format_rounds_payloads(m.page_format) ? tree::kRoundedPayloadBytes
                                                                      : codec->bytes_per_node();

  // 1. Page table.
  r.fill_min = m.pages.empty() ? 0 : std::numeric_limits<double>::infinity();
  for (const PageExtent& e : m.pages) {
    r.page_bytes_total += e.bytes;
    const double fill = double(e.bytes) / m.options.page_size;
    r.fill_min = std::min(r.fill_min, fill);
    r.fill_max = std::max(r.fill_max, fill);
  }
  if (!m.pages.empty()) r.fill_mean = double(r.page_bytes_total) / (double(m.pages.size()) * m.options.page_size);
  r.padding_bytes = m.stats.file_bytes - r.page_bytes_total;
  if (!walk) return r;

  // 2. Walk from the root; one page is kept at hand so that consecutive
  //    nodes of a page do not go through the cache each time.
  struct Item {
    tree::NodeRef ref;
    uint32_t depth, path_pages;
  };
  std::vector<Item> stack{{m.root, 0, 1}};
  std::vector<uint8_t> reached(m.pages.size(), 0);
  tree::PagePtr page;
  uint64_t depth_sum = 0, path_sum = 0;
  r.leaf_depth_min = std::numeric_limits<uint32_t>::max();
  while (!stack.empty()) {
    const Item it = stack.back();
    stack.pop_back();
    if (!page || page->id != it.ref.page) page = reader.page(it.ref.page);
    reached[it.ref.page] = 1;
    const tree::Node& n = page->nodes.at(it.ref.index);
    ++r.nodes;
    if (n.is_leaf()) {
      ++r.leaves;
      r.surfels += n.surfel_count;
      depth_sum += it.depth;
      path_sum += it.path_pages;
      r.leaf_depth_min = std::min(r.leaf_depth_min, it.depth);
      r.leaf_depth_max = std::max(r.leaf_depth_max, it.depth);
      r.path_pages_max = std::max(r.path_pages_max, it.path_pages);
    }
    for (uint32_t c = n.child_count; c-- > 0;) {
      const tree::NodeRef child = n.children[c];
      stack.push_back({child, it.depth + 1, it.path_pages + (child.page != it.ref.page ? 1u : 0u)});
    }
  }
  r.walked = true;
  r.pages_reached = static_cast<uint32_t>(std::count(reached.begin(), reached.end(), 1));
  if (r.leaves > 0) {
    r.leaf_depth_mean = double(depth_sum) / r.leaves;
    r.path_pages_mean = double(path_sum) / r.leaves;
    r.leaf_surfels_mean = double(r.surfels) / r.leaves;
  } else {
    r.leaf_depth_min = 0;
  }
  r.consistent = r.nodes == m.stats.node_count && r.leaves == m.stats.leaf_count &&
                 r.surfels == m.stats.surfel_count && r.leaf_depth_max == m.stats.max_depth &&
                 r.pages_reached == m.stats.page_count;
  return r;
}

}  // namespace pbgi::storage
