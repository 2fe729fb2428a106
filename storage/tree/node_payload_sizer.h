// The hook through which the streaming build stores a payload for every
// node (build option tree.payload_codec float32-sh / kmeans-sh; FORMAT.md,
// "Payload storage"). The tree library knows nothing of codecs: the page-set
// build adapts its PayloadCodec to this interface.
//
// The builder asks for each node's stored size as soon as the node is
// complete (post-order), so that it knows every pending treelet's size on
// disk exactly and never writes a page above page_size. The treelet then
// carries its nodes' *exact* summaries to the page writer, whose codec
// quantizes each node independently (kmeans-sh: the LUT search, in
// parallel over the page). Parents always average the children's exact
// payloads, which the open part of the tree keeps until the children's page
// is written, so quantization errors never accumulate up the tree: the
// stored tree equals quantizing a finished exact tree node by node
// (tests/storage/pages/payload_codec_build_test.cpp).
//
// Thread-safety: bits() is called from the building thread only.
#pragma once

#include "storage/tree/node.h"

#include <cstdint>

namespace pbgi::tree {

class NodePayloadSizer {
 public:
  virtual ~NodePayloadSizer() = default;
  // Bits `node`'s payload takes on disk; a page's payload array takes
  // ceil(sum of its nodes' bits / 8) bytes. Depends on the node only.
  virtual uint32_t bits(const Node& node) const = 0;
};

}  // namespace pbgi::tree
