#include "storage/tree/leaf_quantizer.h"

#include "storage/tree/bounding_sphere.h"

#include <cmath>
#include <limits>

namespace pbgi::tree {

storage::LeafFrame quantize_leaf(storage::LeafFormat format, std::span<const Surfel> surfels,
                                 uint8_t* records, std::span<Surfel> decoded) {
  const size_t record_bytes = storage::surfel_record_bytes(format);
  const Sphere tight = sphere_of_disks(surfels);
  storage::LeafFrame f;
  f.center = tight.center;
  // Decoding moves a disk's farthest point by at most ~1.5e-4 R (relative:
  // position R/65534 per axis, radius R/131070, normal 1e-4 rad times
  // r <= R; half: radius R/4096, normal 1e-3 rad times r): a 2^-11 margin
  // mostly suffices the first time, and the loop below widens otherwise.
  f.radius = tight.radius * (1.f + 0x1p-11f);
  for (int attempt = 0;; ++attempt) {
    double farthest = 0;
    for (size_t i = 0; i < surfels.size(); ++i) {
      uint8_t* rec = records + i * record_bytes;
      storage::encode_surfel_record(format, surfels[i], f, rec);
      storage::decode_surfel_record(format, rec, f, decoded[i]);
      farthest = std::max(farthest, farthest_disk_distance(
                                        Imath::V3d(f.center.x, f.center.y, f.center.z), decoded[i]));
    }
    if (farthest <= double(f.radius)) return f;
    // Widen and re-encode (offsets are relative to the radius, so every
    // record changes). Doubling the margin each time ends in a few steps.
    const float grow = 1.f + std::ldexp(1.f, -10 + attempt);
    f.radius = std::max(f.radius * grow, std::nextafter(float(farthest), std::numeric_limits<float>::infinity()));
  }
}

}  // namespace pbgi::tree
