// The interface of node payload codecs: how a page stores the spherical
// functions (radiance_sh, coverage_sh) of its nodes. A page's payload array
// is produced by one codec for all of its nodes at once, so later codecs
// (k-means-quantized SH, Haar wavelets) may share tables within a page.
// Decoding always yields the same tree::Node fields, whatever the codec:
// the gather sees one in-memory form.
//
// Thread-safety: codec objects are immutable after construction; encode()
// and decode() may run concurrently from any number of threads.
//
// How to add a codec:
//  1. A new CodecId below (never reuse one: page sets on disk name theirs).
//  2. A PayloadCodec in a file of its own (storage/codecs/<name>_codec.h);
//     payload_bits() must predict encode()'s size exactly, and decode()
//     must throw CorruptionError on any size or content it cannot hold.
//     Per-page-set state (a LUT) goes through state() and the manifest.
//  3. Register it in payload_codecs.cpp (make_payload_codec,
//     is_known_payload_codec, codec_needs_state when it has state).
//  4. Make it choosable: a PayloadCodecOption value and name
//     (storage/tree/build_options.h; the config, flags and requests read
//     the names) and its policy in codec_selection.cpp.
//  5. Its layout in storage/format/FORMAT.md; a round-trip test with error
//     bounds in tests/storage/codecs/, and a page of it among the seeds of
//     the page fuzz target (tests/fuzz/make_corpus.cpp). The page format
//     version changes only if the page's own layout does.
#pragma once

#include "storage/tree/node.h"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace pbgi::storage {

// Codec ids as stored in page headers and the manifest. Never reuse an id.
enum class CodecId : uint32_t {
  kFloatSh = 0,      // 27 + 9 float32 SH coefficients, 144 bytes per node
  kQuantizedSh = 1,  // k-means LUT index + log scale, bit-packed (needs its LUT)
  // 2 is reserved and unused: glossy senders' Haar-wavelet radiance is not
  // a node payload codec but a page section beside any of these
  // (storage/codecs/glossy_pages.h, FORMAT.md "Glossy radiance section").
};

class PayloadCodec {
 public:
  virtual ~PayloadCodec() = default;

  virtual uint32_t id() const = 0;
  virtual std::string name() const = 0;
  // On-disk bytes per node; 0 if the size varies with the content.
  virtual size_t bytes_per_node() const = 0;

  // Appends the payloads of `nodes` (radiance_sh, coverage_sh) to `out`.
  virtual void encode(std::span<const tree::Node> nodes, std::vector<uint8_t>& out) const = 0;
  // Size on disk of `node`'s payload in bits: encode() of nodes n_i appends
  // exactly ceil(sum payload_bits(n_i) / 8) bytes, so the streaming build
  // knows a page's size before writing it. Cheap (no LUT search).
  virtual uint32_t payload_bits(const tree::Node& node) const = 0;
  // Serialized per-page-set state (the kmeans-sh LUT), stored in the
  // manifest; empty for stateless codecs.
  virtual std::vector<uint8_t> state() const { return {}; }

  // Decodes `bytes` (the whole payload array of a page) into the payload
  // fields of `nodes`. Throws CorruptionError (prefixed with `what`, e.g.
  // the page's location) if the size does not match.
  virtual void decode(std::span<const uint8_t> bytes, std::span<tree::Node> nodes,
                      const std::string& what) const = 0;
};

// Returns the codec stored under `id`; VersionError if this build does not
// know it (a page set written by a newer pbgi). InvalidArgument for a codec
// that needs state (codec_needs_state()): use the overload below.
std::shared_ptr<const PayloadCodec> make_payload_codec(uint32_t id);

// Whether this build reads codec `id` at all.
bool is_known_payload_codec(uint32_t id);
// Whether codec `id` needs per-page-set state (the quantized SH LUT),
// stored in the page set's metadata and passed to the overload below.
bool codec_needs_state(uint32_t id);
// Returns the codec `id` with its serialized state (ignored by stateless
// codecs). VersionError for an unknown id or state version;
// CorruptionError (prefixed with `what`) for damaged state.
std::shared_ptr<const PayloadCodec> make_payload_codec(uint32_t id, std::span<const uint8_t> state,
                                                       const std::string& what);

}  // namespace pbgi::storage
