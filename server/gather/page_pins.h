// The pages one receiver's traversal holds. Each entry of the traversal
// stack holds a reference to its node's page; a page is fetched from the
// TreeSource when first referenced and released (unpinned) as soon as no
// pending stack entry refers to it any more. Pinning keeps raw Node
// pointers valid even if the page cache evicts the page meanwhile, and
// releasing early bounds what one gather keeps alive to the pages along the
// stack (a few dozen) instead of every page the receiver touched (hundreds
// for a 200k-surfel tree).
//
// Each page entering a traversal also gets its PageView (page_views.h),
// the compact node data the traversal's hot loop reads. From a source
// that keeps views alone (a page set reader decorated with attach_view:
// TreeSource::attachment) the pin holds the view itself; from any other,
// the page, whose view PageViews finds or builds.
//
// Slots live in an append-only array (their numbers stay valid while the
// receiver runs); an open-addressing hash index (linear probing,
// power-of-two size) maps page ids to slots. Nothing allocates per
// receiver once both have grown to the working set.
// Thread-safety: none; one per Gatherer.
#pragma once

#include "common/errors.h"
#include "server/gather/page_views.h"
#include "storage/tree/node.h"

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

namespace pbgi::gather {

class PagePins {
 public:
  PagePins(const tree::TreeSource& tree, PageViews& views)
      : tree_(tree), views_(views), index_(64, Bucket{}) {}

  // Adds a reference to page `id`, fetching it if it is not pinned. Returns
  // the slot to pass to release(); `view` receives the page's traversal
  // view. A pinned page costs one line of the index (its id, slot and
  // view) and a write to its slot: opening a linked child in a page pinned
  // already (every few nodes, with pages of a few levels) waits for one
  // line, then for the view's header and node 0, which share a pair
  // (page_views.h). Throws what the TreeSource throws, CorruptionError if
  // it returns no or another page, or if the view finds broken links.
  uint32_t acquire(uint32_t id, const PageView*& view) {
    Bucket& b = bucket_of(id);
    Slot& slot = slots_[b.slot];
    if (!b.view) {
      ++fetches_;
      // A source that keeps views alone (a page set reader decorated with
      // attach_view) pins the view; any other, the page.
      if (std::shared_ptr<const tree::PageAttachment> a = tree_.attachment(id)) {
        const auto* v = dynamic_cast<const PageView*>(a.get());
        if (!v || v->id != id) {
          throw CorruptionError("tree page " + std::to_string(id) + ": source returned another page's or no view");
        }
        slot.view = v;
        slot.bytes = uint32_t(std::min<uint64_t>(v->memory_bytes(), UINT32_MAX));
        slot.pin = std::move(a);
        slot.page = nullptr;
      } else {
        tree::PagePtr p = tree_.page(id);
        if (!p) throw CorruptionError("tree page " + std::to_string(id) + ": source returned no page");
        if (p->id != id) {
          throw CorruptionError("tree page " + std::to_string(id) + ": source returned page " + std::to_string(p->id));
        }
        slot.view = &views_.get(*p);
        slot.page = p.get();
        slot.bytes = uint32_t(std::min<uint64_t>(p->memory_bytes(), UINT32_MAX));
        slot.pin = std::move(p);
      }
      b.view = slot.view;
      ++pinned_;
      pinned_bytes_ += slot.bytes;
    }
    ++slot.refs;
    slot.touched = epoch_;
    view = b.view;
    return b.slot;
  }
  // The same, with the page, or null when the source keeps views alone.
  uint32_t acquire(uint32_t id, const tree::Page*& page, const PageView*& view) {
    const uint32_t s = acquire(id, view);
    page = slots_[s].page;
    return s;
  }

  // The view of a pinned slot.
  const PageView& view(uint32_t s) const { return *slots_[s].view; }

  // Adds a reference to a pinned slot.
  void retain(uint32_t s) { ++slots_[s].refs; }

  // Drops a reference; the page is unpinned with its last one (unless
  // holding).
  void release(uint32_t s) {
    Slot& slot = slots_[s];
    if (--slot.refs == 0 && !hold_) unpin(s);
  }

  // Unpins everything and forgets all slots (between receivers, and after
  // an exception left references behind).
  void clear() {
    for (const Slot& slot : slots_) index_[slot.bucket] = Bucket{};
    slots_.clear();
    pinned_ = 0;
    pinned_bytes_ = 0;
    ++epoch_;
  }

  // Between the runs of a batch that holds its pages (no references left):
  // starts a new run, so that trim() knows which pages the recent runs used.
  void next_run() { ++epoch_; }

  // Unpins the pages least recently used (by run) that no pending entry
  // refers to, until the pinned ones cost at most `keep_bytes` (or none of
  // those is left). A batch thus keeps the pages its recent runs used,
  // which the next runs mostly use again, within a bound in bytes; slots
  // stay where they are, so it may run between a cluster's receivers while
  // its near entries hold theirs. Pinned pages are memory beside the page
  // cache's budget (storage/cache/page_cache.h reports them as
  // bytes_pinned).
  void trim(uint64_t keep_bytes) {
    if (pinned_bytes_ <= keep_bytes) return;
    // Oldest run first, then slot: keys of both in one word, sorted
    // without a look into the slots (a trim sorts thousands).
    std::vector<uint64_t> order;
    order.reserve(pinned_);
    for (uint32_t s = 0; s < slots_.size(); ++s) {
      if (slots_[s].pin && slots_[s].refs == 0) order.push_back(uint64_t(slots_[s].touched) << 32 | s);
    }
    std::sort(order.begin(), order.end());
    for (const uint64_t key : order) {
      if (pinned_bytes_ <= keep_bytes) break;
      unpin(uint32_t(key));
    }
  }

  // Between the runs of a batch (no references left): forgets the slots of
  // unpinned pages once they outnumber the pinned ones, so that the slots
  // and the index stay the size of what is pinned, not of the tens of
  // thousands of pages a batch fetches (trim() leaves slots in place).
  void compact() {
    if (slots_.size() <= 2 * pinned_ + 1024) return;
    std::vector<Slot> old;
    old.swap(slots_);
    std::fill(index_.begin(), index_.end(), Bucket{});
    for (Slot& slot : old) {
      if (!slot.pin) continue;
      slots_.push_back(std::move(slot));
      place(uint32_t(slots_.size() - 1));
    }
  }

  // While holding, pages stay pinned until clear() even without references:
  // a factorized cluster revisits the same pages for each of its receivers.
  void set_hold(bool hold) { hold_ = hold; }

  // Pages pinned right now, and their bytes (PageAttachment::memory_bytes
  // or Page::memory_bytes).
  size_t pinned() const { return pinned_; }
  uint64_t pinned_bytes() const { return pinned_bytes_; }
  // Pages fetched from the TreeSource since the last take_fetches().
  uint64_t take_fetches() {
    const uint64_t f = fetches_;
    fetches_ = 0;
    return f;
  }

 private:
  static constexpr uint32_t kNone = ~0u;
  // An entry of the open-addressing index: what acquire() reads of a
  // pinned page, in one 16-byte cell.
  struct Bucket {
    uint32_t id = 0;
    uint32_t slot = kNone;          // kNone: empty
    const PageView* view = nullptr;  // null while the slot's page is not pinned
  };
  struct Slot {
    uint32_t id = 0;
    uint32_t refs = 0;
    uint32_t bucket = 0;   // its position in index_
    uint32_t touched = 0;  // epoch_ of its last acquire()
    uint32_t bytes = 0;    // what the pinned page or view costs
    std::shared_ptr<const void> pin;   // the page or its view; null when released
    const tree::Page* page = nullptr;  // the pinned page, if pinned as a page
    const PageView* view = nullptr;
  };
  static size_t hash(uint32_t id) { return size_t(id) * 0x9E3779B1u; }

  // Drops slot `s`'s pin; the slot stays, its index cell says unpinned.
  void unpin(uint32_t s) {
    Slot& slot = slots_[s];
    slot.pin.reset();
    slot.page = nullptr;
    index_[slot.bucket].view = nullptr;
    --pinned_;
    pinned_bytes_ -= slot.bytes;
  }

  // The bucket of page `id`, with a new slot (released, no references) if
  // the page has none.
  Bucket& bucket_of(uint32_t id) {
    size_t mask = index_.size() - 1;
    size_t b = hash(id) & mask;
    for (; index_[b].slot != kNone; b = (b + 1) & mask) {
      if (index_[b].id == id) return index_[b];
    }
    if (2 * (slots_.size() + 1) > index_.size()) {
      rehash(2 * index_.size());
      mask = index_.size() - 1;
      b = hash(id) & mask;
      while (index_[b].slot != kNone) b = (b + 1) & mask;
    }
    const uint32_t s = uint32_t(slots_.size());
    slots_.push_back({id, 0, uint32_t(b), epoch_, 0, nullptr, nullptr, nullptr});
    index_[b] = {id, s, nullptr};
    return index_[b];
  }

  // Enters slot `s` in the index.
  void place(uint32_t s) {
    Slot& slot = slots_[s];
    const size_t mask = index_.size() - 1;
    size_t b = hash(slot.id) & mask;
    while (index_[b].slot != kNone) b = (b + 1) & mask;
    index_[b] = {slot.id, s, slot.pin ? slot.view : nullptr};
    slot.bucket = uint32_t(b);
  }

  void rehash(size_t size) {
    index_.assign(size, Bucket{});
    for (uint32_t s = 0; s < slots_.size(); ++s) place(s);
  }

  const tree::TreeSource& tree_;
  PageViews& views_;
  std::vector<Slot> slots_;
  std::vector<Bucket> index_;
  size_t pinned_ = 0;
  uint64_t pinned_bytes_ = 0;
  uint64_t fetches_ = 0;
  uint32_t epoch_ = 0;  // advanced by clear() and next_run()
  bool hold_ = false;
};

// Clears a PagePins when the scope ends (also on errors): a receiver's
// pages stay pinned only while it is gathered.
struct ClearPinsOnExit {
  PagePins& pins;
  ~ClearPinsOnExit() { pins.clear(); }
};

// Holds pages pinned without references (PagePins::set_hold) while the
// scope lasts, for a batch of receivers that revisits the same pages;
// unpins everything when it ends (also on errors).
struct HoldPinsInScope {
  explicit HoldPinsInScope(PagePins& p) : pins(p) { pins.set_hold(true); }
  ~HoldPinsInScope() {
    pins.clear();
    pins.set_hold(false);
  }
  HoldPinsInScope(const HoldPinsInScope&) = delete;
  HoldPinsInScope& operator=(const HoldPinsInScope&) = delete;
  PagePins& pins;
};

}  // namespace pbgi::gather
