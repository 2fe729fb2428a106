// Options of the tree build and page layout (documented defaults).
#pragma once

#include "storage/format/page_records.h"

#include <cstdint>
#include <string>

namespace pbgi::tree {

// How a page set stores node payloads (storage/format/FORMAT.md, "Payload
// storage"). As written in config files, CLI flags and requests:
//   derived     no node payload stored (only the linked children's, float32):
//               every payload is recomputed from the decoded surfels when a
//               page loads. Smallest for small trees, exact, costs CPU per load.
//   float32-sh  every node stores its payload as 36 float32 (144 B): loads
//               copy payloads, nothing to recompute. Lossless.
//   kmeans-sh   every node stores a LUT index + log scale, bit-packed
//               (Buchholz & Boubekeur 2012); the LUT is learned on a sample
//               tree and stored in the manifest. Lossy.
//   auto        what the scene needs (storage/codecs/codec_selection.h):
//               derived for diffuse senders (measured smallest, exact, as fast
//               to load: docs/codecs.md); glossy wavelets once they exist.
enum class PayloadCodecOption : uint8_t { kDerived = 0, kFloatSh = 1, kQuantizedSh = 2, kAuto = 3 };

// InvalidArgument naming the accepted values for anything else.
PayloadCodecOption parse_payload_codec(const std::string& name);
std::string to_string(PayloadCodecOption option);

struct BuildOptions {
  uint32_t leaf_size = 4;        // max surfels per leaf node (1..4096)
  uint32_t page_size = 65536;    // max bytes per page on disk
  // Memory for sorting surfels by Morton code: the run buffer while surfels
  // arrive, then all merge buffers together. Runs beyond it go to disk.
  // Changes only speed and memory, never the page set (so it is neither
  // stored in the manifest nor part of build keys).
  uint64_t sort_memory_bytes = uint64_t(256) << 20;
  // Node payload storage (above). The default keeps the V2 behaviour.
  PayloadCodecOption payload_codec = PayloadCodecOption::kDerived;
  // kmeans-sh: LUT size l (64 .. 65536); indices take ceil(log2 l) bits.
  uint32_t lut_entries = 4096;
  // kmeans-sh: share of the surfels (chosen at random, deterministically by
  // arrival index) over which the sample tree that trains the LUT is built,
  // in (0, 1]; at least 20000 surfels and 16 per LUT entry are taken.
  double lut_sample_fraction = 0.02;
  // Glossy senders (surfels with a specular lobe, storage/tree/surfel.h):
  // their outgoing radiance is stored as Haar-wavelet cube maps of
  // glossy_resolution^2 pixels per face (8, 16 or 32), coded down each
  // page (storage/codecs/glossy_pages.h); detail blocks (one face) whose
  // L2 norm is below wavelet_threshold are dropped (0 keeps every non-zero
  // block: exact). Scenes without glossy surfels never pay for them.
  uint32_t glossy_resolution = 16;
  float wavelet_threshold = 0.f;
  // How leaves store surfels (storage/format/page_records.h): relative
  // (the paper's format B, 24 B per surfel, the default) or half (format
  // A, 38 B: float32 positions, half-float colours).
  storage::LeafFormat leaf_format = storage::LeafFormat::kRelative;

  void validate() const;  // throws pbgi::InvalidArgument
};

}  // namespace pbgi::tree
