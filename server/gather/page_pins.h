// The pages one receiver's traversal holds: fetched from the TreeSource on
// first use, kept alive (pinned) while the receiver is gathered, released
// all at once by clear(). Pinning keeps raw Node pointers valid during the
// traversal even if the page cache evicts the page meanwhile.
//
// An open-addressing hash table (linear probing, power-of-two size) so that
// neither lookups nor clear() allocate once it has grown to the working set.
// Thread-safety: none; one per Gatherer.
#pragma once

#include "storage/format/errors.h"
#include "storage/tree/node.h"

#include <cstdint>
#include <string>
#include <vector>

namespace pbgi::gather {

class PagePins {
 public:
  explicit PagePins(const tree::TreeSource& tree) : tree_(tree), slots_(64) {}

  // The page with `id`, fetching and pinning it on first use. Throws what
  // the TreeSource throws, or CorruptionError if it returns no page.
  const tree::Page* get(uint32_t id) {
    if (last_ != nullptr && last_->id == id) return last_;
    size_t mask = slots_.size() - 1;
    for (size_t s = hash(id) & mask;; s = (s + 1) & mask) {
      Slot& slot = slots_[s];
      if (!slot.page) break;
      if (slot.id == id) return last_ = slot.page.get();
    }
    tree::PagePtr page = tree_.page(id);
    ++fetches_;
    if (!page) throw CorruptionError("tree page " + std::to_string(id) + ": source returned no page");
    if (page->id != id) {
      throw CorruptionError("tree page " + std::to_string(id) + ": source returned page " +
                            std::to_string(page->id));
    }
    if (2 * (used_.size() + 1) > slots_.size()) grow();
    mask = slots_.size() - 1;
    size_t s = hash(id) & mask;
    while (slots_[s].page) s = (s + 1) & mask;
    slots_[s] = {id, std::move(page)};
    used_.push_back(s);
    return last_ = slots_[s].page.get();
  }

  // Unpins every page.
  void clear() {
    for (const size_t s : used_) slots_[s].page.reset();
    used_.clear();
    last_ = nullptr;
  }

  size_t pinned() const { return used_.size(); }
  // Pages fetched from the TreeSource since the last take_fetches().
  uint64_t take_fetches() {
    const uint64_t f = fetches_;
    fetches_ = 0;
    return f;
  }

 private:
  struct Slot {
    uint32_t id = 0;
    tree::PagePtr page;
  };
  static size_t hash(uint32_t id) { return size_t(id) * 0x9E3779B1u; }

  void grow() {
    std::vector<Slot> old(slots_.size() * 2);
    old.swap(slots_);
    used_.clear();
    const size_t mask = slots_.size() - 1;
    for (Slot& o : old) {
      if (!o.page) continue;
      size_t s = hash(o.id) & mask;
      while (slots_[s].page) s = (s + 1) & mask;
      slots_[s] = std::move(o);
      used_.push_back(s);
    }
  }

  const tree::TreeSource& tree_;
  std::vector<Slot> slots_;
  std::vector<size_t> used_;
  const tree::Page* last_ = nullptr;
  uint64_t fetches_ = 0;
};

}  // namespace pbgi::gather
