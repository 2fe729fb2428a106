#include "storage/tree/leaf_quantizer.h"

#include "storage/tree/bounding_sphere.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pbgi::tree {

namespace {
// The emission entries of the records that say they emit; the decoded
// surfels get the entries' value, as a reader gets it.
void add_emission(storage::SurfelRecords format, std::span<const Surfel> surfels, const uint8_t* records,
                  std::span<Surfel> decoded, std::vector<uint8_t>& emission) {
  const size_t record_bytes = storage::surfel_record_bytes(format);
  for (size_t i = 0; i < surfels.size(); ++i) {
    if (!storage::surfel_record_emits(format, records + i * record_bytes)) continue;
    const size_t at = emission.size();
    emission.resize(at + storage::kEmissionEntryBytes);
    storage::write_emission_entry(surfels[i], emission.data() + at);
    decoded[i].emission = storage::read_emission_entry(emission.data() + at);
  }
}
}  // namespace

storage::LeafFrame quantize_leaf(storage::SurfelRecords format, std::span<const Surfel> surfels, uint8_t* records,
                                 std::span<Surfel> decoded, std::vector<uint8_t>& emission) {
  const size_t record_bytes = storage::surfel_record_bytes(format);
  const Sphere tight = sphere_of_disks(surfels);
  storage::LeafFrame f;
  f.center = tight.center;
  // Decoding moves a disk's farthest point by at most ~1.5e-4 R (relative:
  // position R/65534 per axis, radius R/131070, normal 1e-4 rad times
  // r <= R; half: radius R/4096, normal 1e-3 rad times r; compact: up to
  // ~1.4e-3 R, position R/16382 per axis, radius R/16382, normal 1.2e-3
  // rad times r, though most normals move far less; positions on a coarser
  // grid, page_records.h position_grid_shift, up to 16 R/8191 per axis): a
  // 2^-11 margin mostly suffices the first time, and the loop below widens
  // otherwise.
  f.radius = tight.radius * (1.f + 0x1p-11f);
  // The tree's frames are rounded (page_records.h RoundedFrame), so that
  // V8/V9 leaf records hold them exactly: the surfels are quantized in the
  // rounded frame, which contains the sphere it rounds.
  f = storage::round_frame_outward(f, storage::kLeafFrameGridBits).frame();
  float smallest = std::numeric_limits<float>::infinity();
  for (const Surfel& s : surfels) smallest = std::min(smallest, s.radius);
  for (int attempt = 0;; ++attempt) {
    const int shift = storage::position_grid_shift(f.radius, smallest);
    double farthest = 0;
    for (size_t i = 0; i < surfels.size(); ++i) {
      uint8_t* rec = records + i * record_bytes;
      storage::encode_surfel_record(format, surfels[i], f, rec, shift);
      storage::decode_surfel_record(format, rec, f, decoded[i]);
      farthest = std::max(farthest, farthest_disk_distance(
                                        Imath::V3d(f.center.x, f.center.y, f.center.z), decoded[i]));
    }
    if (farthest <= double(f.radius)) {
      if (storage::emission_out_of_line(format)) add_emission(format, surfels, records, decoded, emission);
      return f;
    }
    // Widen and re-encode (offsets are relative to the radius, so every
    // record changes). Doubling the margin each time ends in a few steps.
    const float grow = 1.f + std::ldexp(1.f, -10 + attempt);
    f.radius = std::max(f.radius * grow, std::nextafter(float(farthest), std::numeric_limits<float>::infinity()));
    f = storage::round_frame_outward(f, storage::kLeafFrameGridBits).frame();
  }
}

}  // namespace pbgi::tree
