#include "storage/tree/treelet.h"

#include "common/errors.h"
#include "storage/format/packed_values.h"
#include "storage/tree/node_summary.h"
#include "storage/tree/page_records.h"
#include "storage/tree/scratch_arrays.h"

#include <array>
#include <vector>

namespace pbgi::tree {

size_t Treelet::surfel_count() const { return surfel_records.size() / storage::surfel_record_bytes(records); }

namespace {
void copy_payload(const Node& from, Node& to) {
  to.radiance_sh = from.radiance_sh;
  to.coverage_sh = from.coverage_sh;
}
}  // namespace

namespace {

// Parse state of expand_treelet(), kept per thread between calls (pages
// are expanded on every page cache miss); arrays a large page grew are
// freed after it.
struct ExpandScratch {
  std::vector<storage::NodeShape> shape;
  std::vector<std::array<uint32_t, 2>> link_of;
  std::vector<storage::LeafFrame> frame;
  struct Open {
    uint32_t node;
    uint32_t slot;  // the next child slot to visit
  };
  std::vector<Open> stack;

  void trim() {
    trim_scratch(shape);
    trim_scratch(link_of);
    trim_scratch(frame);
    trim_scratch(stack);
  }
};

}  // namespace

void Treelet::clear() {
  shapes.clear();
  leaf_records.clear();
  links.clear();
  surfel_records.clear();
  emission.clear();
  nodes.clear();
  gloss.clear();
}

void expand_treelet(const TreeletView& t, uint32_t page_id, const std::string& what, Page& out) {
  using namespace storage;
  auto corrupt = [&](const std::string& msg) { return CorruptionError(what + ": " + msg); };
  const size_t n = t.shapes.size();
  const bool decoded_leaves = !t.leaves.empty();
  const size_t leaves = decoded_leaves ? t.leaves.size() : t.leaf_records.size() / kLeafRecordBytes;
  const size_t record_bytes = surfel_record_bytes(t.records);
  const size_t surfels = t.surfel_records.size() / record_bytes;
  if (n == 0) throw corrupt("page has no nodes");
  const bool stored = !t.payloads.empty();
  const PayloadMode mode = stored               ? PayloadMode::kNone
                           : t.rounded_payloads ? PayloadMode::kRounded
                                                : PayloadMode::kExact;
  const BoundsMode bounds = t.rounded_bounds ? BoundsMode::kRounded : BoundsMode::kExact;
  if (stored && t.payloads.size() != n) {
    throw corrupt(std::to_string(t.payloads.size()) + " stored payloads for " + std::to_string(n) + " nodes");
  }
  out.id = page_id;
  out.nodes.assign(n, Node{});
  out.surfels.assign(surfels, Surfel{});
  out.links.clear();
  out.links.reserve(t.links.size());

  // 1. Structure: parse the shapes in pre-order with an explicit stack (a
  //    damaged page must not be able to recurse deeply).
  thread_local ExpandScratch scratch;
  struct Trim {
    ExpandScratch& s;
    ~Trim() { s.trim(); }
  } trim{scratch};
  std::vector<storage::NodeShape>& shape = scratch.shape;
  shape.assign(n, storage::NodeShape{});
  std::vector<std::array<uint32_t, 2>>& link_of = scratch.link_of;  // link index per external slot
  link_of.assign(n, {});
  std::vector<LeafFrame>& frame = scratch.frame;
  frame.assign(leaves, LeafFrame{});
  std::vector<ExpandScratch::Open>& stack = scratch.stack;
  stack.clear();
  size_t next = 0, leaf = 0, link = 0;
  uint64_t first_surfel = 0;
  auto open = [&](uint32_t i) {
    if (t.max_levels != 0 && stack.size() >= t.max_levels) {
      throw corrupt("node " + std::to_string(i) + " lies " + std::to_string(stack.size() + 1) +
                    " levels deep in the page, more than the format's " + std::to_string(t.max_levels));
    }
    if (!decode_shape(t.shapes[i], shape[i])) {
      throw corrupt("node " + std::to_string(i) + " has an invalid shape byte " +
                    std::to_string(t.shapes[i]));
    }
    Node& node = out.nodes[i];
    node.child_count = shape[i].child_count;
    if (node.child_count > 0) {
      stack.push_back({i, 0});
      return;
    }
    if (leaf >= leaves) throw corrupt("more leaves than the " + std::to_string(leaves) + " leaf records");
    uint32_t count = 0;
    if (decoded_leaves) {
      frame[leaf] = t.leaves[leaf].frame;
      count = t.leaves[leaf].surfel_count;
    } else {
      read_leaf_record(t.leaf_records.data() + leaf * kLeafRecordBytes, frame[leaf], count);
    }
    if (count == 0 || first_surfel + count > surfels) {
      throw corrupt("leaf " + std::to_string(leaf) + " (node " + std::to_string(i) + ") has surfels [" +
                    std::to_string(first_surfel) + ", +" + std::to_string(count) + ") outside the page's " +
                    std::to_string(surfels));
    }
    node.first_surfel = static_cast<uint32_t>(first_surfel);
    node.surfel_count = count;
    node.children[0].index = static_cast<uint32_t>(leaf);  // frame index, until step 2
    first_surfel += count;
    ++leaf;
  };
  open(static_cast<uint32_t>(next++));
  while (!stack.empty()) {
    const ExpandScratch::Open top = stack.back();
    if (top.slot == shape[top.node].child_count) {
      stack.pop_back();
      continue;
    }
    ++stack.back().slot;
    Node& node = out.nodes[top.node];
    if (shape[top.node].external[top.slot]) {
      if (link >= t.links.size()) throw corrupt("more links than the " + std::to_string(t.links.size()) + " link records");
      const uint32_t target = t.links[link].page;
      if (target >= page_id) {
        throw corrupt("node " + std::to_string(top.node) + " links to page " + std::to_string(target) +
                      ", not written before this one");
      }
      node.children[top.slot] = {target, 0};
      PageLink& l = out.links.emplace_back();
      l.parent = top.node;
      l.slot = top.slot;
      l.summary = t.links[link].summary;
      l.summary.child_count = 0;
      l.summary.first_surfel = l.summary.surfel_count = 0;
      l.summary.children[0] = {target, 0};
      l.summary.children[1] = {};
      link_of[top.node][top.slot] = static_cast<uint32_t>(link++);
    } else {
      if (next >= n) throw corrupt("node " + std::to_string(top.node) + " has a child past the " + std::to_string(n) + " nodes");
      node.children[top.slot] = {page_id, static_cast<uint32_t>(next)};
      open(static_cast<uint32_t>(next++));
    }
  }
  if (next != n || leaf != leaves || link != t.links.size() || first_surfel != surfels) {
    throw corrupt("shapes describe " + std::to_string(next) + " nodes, " + std::to_string(leaf) + " leaves, " +
                  std::to_string(link) + " links, " + std::to_string(first_surfel) + " surfels; the page holds " +
                  std::to_string(n) + ", " + std::to_string(leaves) + ", " + std::to_string(t.links.size()) +
                  ", " + std::to_string(surfels));
  }

  // 2. Emission entries, in surfel order, of the records that emit (none
  //    for layouts that keep emission in the record). Set after the
  //    records are decoded (step 3), which zero it.
  size_t emitting = 0;
  for (size_t k = 0; k < surfels; ++k) {
    emitting += surfel_record_emits(t.records, t.surfel_records.data() + k * record_bytes) ? 1 : 0;
  }
  if (emitting * kEmissionEntryBytes != t.emission.size()) {
    throw corrupt(std::to_string(emitting) + " surfel records emit, the page has " + std::to_string(t.emission.size()) +
                  " bytes of emission entries (" + std::to_string(kEmissionEntryBytes) + " each)");
  }

  // 3. Summaries, children first (reverse pre-order), exactly as the build
  //    computed them.
  for (size_t i = n; i-- > 0;) {
    Node& node = out.nodes[i];
    if (node.child_count == 0) {
      const LeafFrame& f = frame[node.children[0].index];
      node.children[0].index = 0;
      Surfel* s = out.surfels.data() + node.first_surfel;
      const uint8_t* rec = t.surfel_records.data() + size_t(node.first_surfel) * record_bytes;
      for (uint32_t k = 0; k < node.surfel_count; ++k) {
        decode_surfel_record(t.records, rec + k * record_bytes, f, s[k]);
      }
      const uint32_t first = node.first_surfel;
      summarize_leaf({s, node.surfel_count}, f, node, mode, bounds);
      node.first_surfel = first;
      if (stored) copy_payload(t.payloads[i], node);
      continue;
    }
    const Node* child[2] = {nullptr, nullptr};
    for (uint32_t c = 0; c < node.child_count; ++c) {
      child[c] = shape[i].external[c] ? &t.links[link_of[i][c]].summary : &out.nodes[node.children[c].index];
    }
    const NodeRef links[2] = {node.children[0], node.children[1]};
    summarize_internal(*child[0], child[1], node, mode, bounds);
    if (stored) copy_payload(t.payloads[i], node);
    node.children[0] = links[0];
    node.children[1] = links[1];
  }
  if (t.records == SurfelRecords::kCompactSharedAlbedo) {
    const Imath::C3f albedo = decode_rgb9e5(t.shared_albedo);
    for (Surfel& s : out.surfels) s.albedo = albedo;
  }
  for (size_t k = 0, e = 0; e < emitting; ++k) {
    if (!surfel_record_emits(t.records, t.surfel_records.data() + k * record_bytes)) continue;
    out.surfels[k].emission = read_emission_entry(t.emission.data() + e * kEmissionEntryBytes);
    ++e;
  }
}

}  // namespace pbgi::tree
