// The page table of a page set: where each page lies in pages.pbgp.
//
// Why not a vector of (offset, bytes). The table stays in memory while a
// page set is open and grows with its build, one entry a page: at 16
// bytes an entry, the 71.6 M pages of 1.02 G surfels took 1.15 GB, more
// than half of a 2 GiB budget. Pages are written back to back (every V5+
// manifest says so), so a page's offset is the sum of the sizes before it:
// the table keeps each page's size in 16 bits and, for every kGroup pages,
// the offset of the first. That is ~2.25 bytes a page; a lookup adds at
// most kGroup - 1 sizes (a few ns, beside the microseconds of the read it
// serves). Sizes of 65535 bytes and more (a page of exactly 64 KiB, or a
// larger page_size) are kept apart, sorted by page id.
//
// Tables of older manifests (V1-V4) store offsets, which need not follow
// one another; a table whose pages do not lie back to back keeps explicit
// extents instead (16 bytes a page, as before).
//
// Thread-safety: const members may be called concurrently.
#pragma once

#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <iterator>
#include <utility>
#include <vector>

namespace pbgi::storage {

// Where one page lives in pages.pbgp.
struct PageExtent {
  uint64_t offset = 0;
  uint32_t bytes = 0;
  bool operator==(const PageExtent&) const = default;
};

class PageTable {
 public:
  static constexpr uint32_t kGroup = 32;

  PageTable() = default;
  PageTable(std::initializer_list<PageExtent> extents);

  // Appends the extent of the next page id.
  void push_back(PageExtent e);
  void reserve(size_t pages);
  // What reserve(pages) holds in a table of pages back to back, none of
  // 64 KiB or more (every table a build writes, but for such pages): what
  // a build charges before it grows its table.
  static uint64_t bytes_for(size_t pages) {
    return uint64_t(pages) * sizeof(uint16_t) + uint64_t((pages + kGroup - 1) / kGroup) * sizeof(uint64_t);
  }
  // Gives back what growth by push_back reserved beyond size().
  void shrink_to_fit();

  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  // The extent of page `id` (< size()).
  PageExtent operator[](uint32_t id) const;
  // The same, or std::out_of_range past the end.
  PageExtent at(uint32_t id) const;
  // Whether every page follows the previous one from offset 0.
  bool back_to_back() const { return !explicit_mode_; }
  // Heap bytes the table holds (its capacity), for memory budgets.
  uint64_t memory_bytes() const;

  bool operator==(const PageTable& o) const;

  class Iterator {
   public:
    using iterator_category = std::input_iterator_tag;
    using value_type = PageExtent;
    using difference_type = std::ptrdiff_t;
    using pointer = void;
    using reference = PageExtent;
    Iterator(const PageTable* t, uint32_t id) : t_(t), id_(id) {}
    PageExtent operator*() const { return (*t_)[id_]; }
    Iterator& operator++() {
      ++id_;
      return *this;
    }
    bool operator==(const Iterator& o) const { return id_ == o.id_; }

   private:
    const PageTable* t_;
    uint32_t id_;
  };
  Iterator begin() const { return {this, 0}; }
  Iterator end() const { return {this, uint32_t(size_)}; }

 private:
  static constexpr uint16_t kLarge = 0xffff;  // the size is in large_
  uint32_t size_of(uint32_t id) const;
  void make_explicit();

  size_t size_ = 0;
  uint64_t end_ = 0;                                  // where the next page would follow
  std::vector<uint64_t> bases_;                       // offset of pages 0, kGroup, 2 kGroup, ...
  std::vector<uint16_t> sizes_;                       // bytes, or kLarge
  std::vector<std::pair<uint32_t, uint32_t>> large_;  // (id, bytes), ids ascending
  bool explicit_mode_ = false;
  std::vector<PageExtent> explicit_;  // pages not back to back: all extents
};

}  // namespace pbgi::storage
