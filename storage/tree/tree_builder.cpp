#include "storage/tree/tree_builder.h"

#include "common/errors.h"
#include "storage/tree/morton.h"
#include "storage/tree/streaming_tree_builder.h"
#include "storage/tree/surfel_checks.h"

#include <tbb/parallel_sort.h>

#include <string>

namespace pbgi::tree {

namespace {
// Keeps the one treelet of an unbounded build.
class KeepTreelet final : public TreeletSink {
 public:
  uint32_t write(const Treelet& t) override {
    if (written_) throw Error("internal: an unbounded tree build wrote more than one page");
    written_ = true;
    treelet = t;
    return 0;
  }
  Treelet treelet;

 private:
  bool written_ = false;
};
}  // namespace

Imath::Box3f surfel_bounds(const std::vector<Surfel>& surfels) {
  Imath::Box3f b;
  for (const Surfel& s : surfels) b.extendBy(s.position);
  return b;
}

BuiltTree build_tree(std::vector<Surfel> surfels, const BuildOptions& options) {
  options.validate();
  if (surfels.empty()) throw InvalidArgument("cannot build a tree over 0 surfels");
  constexpr size_t kMaxSurfels = size_t(1) << 31;
  if (surfels.size() > kMaxSurfels) {
    throw InvalidArgument("cannot build a tree over " + std::to_string(surfels.size()) +
                          " surfels in memory (at most " + std::to_string(kMaxSurfels) + ")");
  }
  for (size_t i = 0; i < surfels.size(); ++i) check_surfel(surfels[i], i);

  // 1. Morton order, ties in input order (the order the external sort of
  //    build_page_set() produces).
  const MortonFrame frame(surfel_bounds(surfels));
  struct Key {
    uint64_t code;
    uint32_t index;
    bool operator<(const Key& o) const { return code != o.code ? code < o.code : index < o.index; }
  };
  std::vector<Key> keys(surfels.size());
  for (size_t i = 0; i < surfels.size(); ++i) keys[i] = {frame.code(surfels[i].position), uint32_t(i)};
  tbb::parallel_sort(keys.begin(), keys.end());

  // 2. The streaming build into one unbounded page, expanded as a reader
  //    would expand it.
  KeepTreelet sink;
  StreamingTreeBuilder builder(options, 0, 0, sink);
  for (const Key& k : keys) builder.add(surfels[k.index], k.code);
  const StreamingTreeStats stats = builder.finish();
  std::vector<Surfel>().swap(surfels);
  Page page;
  expand_treelet(sink.treelet.view(), 0, "in-memory tree", page);
  BuiltTree t;
  t.nodes = std::move(page.nodes);
  t.surfels = std::move(page.surfels);
  t.leaf_count = stats.leaf_count;
  t.max_depth = stats.max_depth;
  return t;
}

}  // namespace pbgi::tree
