#include "storage/pages/page_table.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace pbgi::storage {

PageTable::PageTable(std::initializer_list<PageExtent> extents) {
  for (const PageExtent& e : extents) push_back(e);
}

void PageTable::reserve(size_t pages) {
  if (explicit_mode_) {
    explicit_.reserve(pages);
    return;
  }
  sizes_.reserve(pages);
  bases_.reserve((pages + kGroup - 1) / kGroup);
}

void PageTable::shrink_to_fit() {
  bases_.shrink_to_fit();
  sizes_.shrink_to_fit();
  large_.shrink_to_fit();
  explicit_.shrink_to_fit();
}

void PageTable::make_explicit() {
  std::vector<PageExtent> all;
  all.reserve(size_ + 1);
  for (uint32_t id = 0; id < size_; ++id) all.push_back((*this)[id]);
  explicit_mode_ = true;
  explicit_ = std::move(all);
  std::vector<uint64_t>().swap(bases_);
  std::vector<uint16_t>().swap(sizes_);
  std::vector<std::pair<uint32_t, uint32_t>>().swap(large_);
}

void PageTable::push_back(PageExtent e) {
  if (!explicit_mode_ && e.offset != end_) make_explicit();
  if (explicit_mode_) {
    explicit_.push_back(e);
  } else {
    if (size_ % kGroup == 0) bases_.push_back(e.offset);
    if (e.bytes >= kLarge) {
      sizes_.push_back(kLarge);
      large_.emplace_back(uint32_t(size_), e.bytes);
    } else {
      sizes_.push_back(uint16_t(e.bytes));
    }
    end_ = e.offset + e.bytes;
  }
  ++size_;
}

uint32_t PageTable::size_of(uint32_t id) const {
  const uint16_t s = sizes_[id];
  if (s != kLarge) return s;
  const auto it = std::lower_bound(large_.begin(), large_.end(), std::pair<uint32_t, uint32_t>(id, 0));
  return it->second;
}

PageExtent PageTable::operator[](uint32_t id) const {
  if (explicit_mode_) return explicit_[id];
  uint64_t offset = bases_[id / kGroup];
  for (uint32_t i = id - id % kGroup; i < id; ++i) offset += size_of(i);
  return {offset, size_of(id)};
}

PageExtent PageTable::at(uint32_t id) const {
  if (id >= size_) {
    throw std::out_of_range("page " + std::to_string(id) + " of a table of " + std::to_string(size_) + " pages");
  }
  return (*this)[id];
}

uint64_t PageTable::memory_bytes() const {
  return bases_.capacity() * sizeof(uint64_t) + sizes_.capacity() * sizeof(uint16_t) +
         large_.capacity() * sizeof(large_[0]) + explicit_.capacity() * sizeof(PageExtent);
}

bool PageTable::operator==(const PageTable& o) const {
  if (size_ != o.size_) return false;
  for (uint32_t id = 0; id < size_; ++id) {
    if ((*this)[id] != o[id]) return false;
  }
  return true;
}

}  // namespace pbgi::storage
