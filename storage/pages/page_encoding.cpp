#include "storage/pages/page_encoding.h"

#include "storage/format/errors.h"
#include "storage/format/page_records.h"

#include <string>

namespace pbgi::storage {

void encode_page(const tree::Page& page, const PayloadCodec& codec, std::vector<uint8_t>& out) {
  const size_t topo_bytes = page.nodes.size() * kTopologyRecordBytes;
  out.assign(kPageHeaderBytes + topo_bytes, 0);
  uint8_t* p = out.data() + kPageHeaderBytes;
  for (const tree::Node& n : page.nodes) {
    write_topology_record(n, p);
    p += kTopologyRecordBytes;
  }
  codec.encode(page.nodes, out);
  const size_t payload_bytes = out.size() - kPageHeaderBytes - topo_bytes;
  const size_t surfels_at = out.size();
  out.resize(surfels_at + page.surfels.size() * kSurfelRecordBytes + kPageTrailerBytes);
  p = out.data() + surfels_at;
  for (const Surfel& s : page.surfels) {
    write_surfel_record(s, p);
    p += kSurfelRecordBytes;
  }

  PageHeader h;
  h.format_version = static_cast<uint16_t>(kPageFormatCurrent);
  h.codec = static_cast<uint16_t>(codec.id());
  h.page_id = page.id;
  h.node_count = static_cast<uint32_t>(page.nodes.size());
  h.surfel_count = static_cast<uint32_t>(page.surfels.size());
  h.payload_bytes = static_cast<uint32_t>(payload_bytes);
  h.page_bytes = static_cast<uint32_t>(out.size());
  write_page_header(h, out.data());
  seal_page(out);
}

tree::PagePtr decode_page(std::span<const uint8_t> bytes, const PageLocation& where,
                          uint32_t expected_version, const PayloadCodec& codec,
                          uint32_t page_count) {
  const PageHeader h = open_page(bytes, where, expected_version);
  const std::string at = where.describe();
  auto corrupt = [&](const std::string& msg) { return CorruptionError(at + ": " + msg); };

  if (h.codec != codec.id()) {
    throw corrupt("payload codec " + std::to_string(h.codec) + " differs from the manifest's " +
                  std::to_string(codec.id()));
  }
  const uint64_t topo_bytes = uint64_t(h.node_count) * kTopologyRecordBytes;
  const uint64_t surfel_bytes = uint64_t(h.surfel_count) * kSurfelRecordBytes;
  const uint64_t need = kPageHeaderBytes + topo_bytes + h.payload_bytes + surfel_bytes + kPageTrailerBytes;
  if (need != bytes.size()) {
    throw corrupt("header counts (" + std::to_string(h.node_count) + " nodes, " +
                  std::to_string(h.payload_bytes) + " payload bytes, " +
                  std::to_string(h.surfel_count) + " surfels) need " + std::to_string(need) +
                  " bytes, page has " + std::to_string(bytes.size()));
  }
  if (h.node_count == 0) throw corrupt("page has no nodes");

  auto page = std::make_shared<tree::Page>();
  page->id = h.page_id;
  page->nodes.resize(h.node_count);
  page->surfels.resize(h.surfel_count);

  // 1. Topology, with every link checked so that no reader can be sent out
  //    of bounds by a page that passed its checksum but was written wrong.
  const uint8_t* p = bytes.data() + kPageHeaderBytes;
  for (uint32_t i = 0; i < h.node_count; ++i, p += kTopologyRecordBytes) {
    tree::Node& n = page->nodes[i];
    read_topology_record(p, n);
    const std::string node = "node " + std::to_string(i);
    if (n.child_count > tree::Node::kMaxChildren) {
      throw corrupt(node + " has " + std::to_string(n.child_count) + " children");
    }
    if (n.is_leaf()) {
      if (n.surfel_count == 0 || uint64_t(n.first_surfel) + n.surfel_count > h.surfel_count) {
        throw corrupt(node + ": leaf surfels [" + std::to_string(n.first_surfel) + ", +" +
                      std::to_string(n.surfel_count) + ") outside the page's " +
                      std::to_string(h.surfel_count));
      }
    }
    for (uint32_t c = 0; c < n.child_count; ++c) {
      const tree::NodeRef r = n.children[c];
      // In-page children come after their parent (pre-order): no cycles.
      const bool ok = r.page == h.page_id ? (r.index > i && r.index < h.node_count) : r.page < page_count;
      if (!ok) {
        throw corrupt(node + ": child link {page " + std::to_string(r.page) + ", index " +
                      std::to_string(r.index) + "} is out of bounds");
      }
    }
  }

  // 2. Payload, through the codec the page set was written with.
  codec.decode(bytes.subspan(kPageHeaderBytes + topo_bytes, h.payload_bytes), page->nodes, at);

  // 3. Surfels.
  p = bytes.data() + kPageHeaderBytes + topo_bytes + h.payload_bytes;
  for (Surfel& s : page->surfels) {
    read_surfel_record(p, s);
    p += kSurfelRecordBytes;
  }
  return page;
}

}  // namespace pbgi::storage
