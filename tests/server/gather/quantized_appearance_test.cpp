// Numerical care for quantized payloads where the gather reads them: a
// kmeans-sh payload is a LUT entry times a scale, so its SH may ring
// differently from the exact one (negative lobes, coverage above 1 or below
// 0 at grazing angles). Whatever the LUT size, every node must show a
// coverage in [0, 1] and a finite, non-negative radiance from every
// direction (node_appearance clamps), and the DC radiance must stay close
// to the exact node's.
#include "server/gather/node_appearance.h"
#include "storage/codecs/quantized_sh_codec.h"
#include "storage/tree/tree_builder.h"
#include "tests/storage/tree/random_surfels.h"

#include <gtest/gtest.h>

#include <random>

namespace pbgi::gather {
namespace {

TEST(QuantizedAppearance, EveryDirectionShowsBoundedNonNegativeLight) {
  const tree::BuiltTree exact = tree::build_tree(test::random_surfels(4000, 17), {});
  for (uint32_t entries : {64u, 1024u}) {
    storage::ShLutOptions lo;
    lo.entries = entries;
    const storage::ShLutTraining training = storage::train_sh_lut(exact.nodes, lo);
    const storage::QuantizedShCodec codec(
        std::make_shared<const storage::QuantizedShTable>(training.table));
    std::mt19937 rng(3);
    std::normal_distribution<float> g;
    size_t visible = 0;
    for (size_t i = 0; i < exact.nodes.size(); i += 3) {
      tree::Node q = exact.nodes[i];
      const storage::QuantizedPayload code = codec.quantize(q);
      if (!code.raw) codec.dequantize(code, q);
      for (int d = 0; d < 64; ++d) {
        Imath::V3f w(g(rng), g(rng), g(rng));
        if (w.length() < 1e-3f) continue;
        w.normalize();
        Appearance a;
        if (!node_appearance(q, w, a)) continue;
        ++visible;
        ASSERT_GE(a.coverage, 0.f) << "node " << i << ", l = " << entries;
        ASSERT_LE(a.coverage, 1.f) << "node " << i << ", l = " << entries;
        for (float c : {a.radiance.x, a.radiance.y, a.radiance.z}) {
          ASSERT_TRUE(std::isfinite(c)) << "node " << i;
          ASSERT_GE(c, 0.f) << "node " << i;
        }
      }
      // The mean radiance (DC ratio) the flat model shows stays close.
      const tree::Node& e = exact.nodes[i];
      const float mean_q = (q.radiance_sh.r[0] + q.radiance_sh.g[0] + q.radiance_sh.b[0]) / q.coverage_sh[0];
      const float mean_e = (e.radiance_sh.r[0] + e.radiance_sh.g[0] + e.radiance_sh.b[0]) / e.coverage_sh[0];
      EXPECT_NEAR(mean_q, mean_e, 0.05f * mean_e + 1e-6f) << "node " << i << ", l = " << entries;
    }
    EXPECT_GT(visible, exact.nodes.size() / 3 * 64 / 4);  // the test looked at something
  }
}

}  // namespace
}  // namespace pbgi::gather
