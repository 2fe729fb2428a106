#include "common/errors.h"
#include "storage/cache/page_cache.h"
#include "storage/codecs/payload_codec.h"
#include "storage/pages/file_io.h"
#include "storage/pages/manifest_file.h"
#include "storage/pages/page_encoding.h"
#include "storage/pages/page_set.h"
#include "storage/tree/scratch_arrays.h"

namespace pbgi::storage {

struct PageSetReader::Impl {
  Impl(const std::filesystem::path& d, std::shared_ptr<PageCache> c, PageDecorator dec)
      : dir(d),
        manifest(read_manifest(d / kManifestFileName)),
        codec(make_payload_codec(manifest.codec, manifest.codec_state, (d / kManifestFileName).string())),
        pages(File::open_read(d / kPagesFileName)),
        cache(std::move(c)),
        decorate(std::move(dec)) {
    const uint64_t size = pages.size();
    if (size != manifest.stats.file_bytes) {
      throw CorruptionError(pages.path() + ": size " + std::to_string(size) +
                            " bytes, the manifest says " + std::to_string(manifest.stats.file_bytes));
    }
    if (cache) owner = cache->new_owner();
  }

  std::filesystem::path dir;
  Manifest manifest;
  std::shared_ptr<const PayloadCodec> codec;
  File pages;
  std::shared_ptr<PageCache> cache;
  PageDecorator decorate;
  uint64_t owner = 0;

  tree::PagePtr load(uint32_t id) const {
    const PageExtent& e = manifest.pages[id];
    std::vector<uint8_t> bytes(e.bytes);
    pages.pread_exact(bytes, e.offset);
    if (cache) cache->note_bytes_read(bytes.size());
    const PageLocation where{pages.path(), id, e.offset};
    if (!decorate) {
      return decode_page(bytes, where, manifest.page_format, *codec, manifest.stats.page_count,
                         manifest.glossy_resolution != 0, manifest.options.leaf_format);
    }
    // Decoded into this thread's scratch page, whose arrays the decorator
    // empties once it has derived what it keeps: the page it returns holds
    // only that, and the next load reuses the arrays, still in the core's
    // caches, instead of allocating and touching new memory (a page cache
    // miss decodes one page).
    thread_local tree::Page scratch;
    struct Reset {
      tree::Page& p;
      ~Reset() {
        p.attachment.reset();
        p.glossy.reset();
        tree::trim_scratch(p.nodes);
        tree::trim_scratch(p.surfels);
        tree::trim_scratch(p.links);
      }
    } reset{scratch};
    decode_page_into(bytes, where, manifest.page_format, *codec, manifest.stats.page_count,
                     manifest.glossy_resolution != 0, manifest.options.leaf_format, nullptr, scratch);
    decorate(scratch);
    auto page = std::make_shared<tree::Page>();
    page->id = scratch.id;
    page->attachment = std::move(scratch.attachment);
    page->glossy = std::move(scratch.glossy);
    page->glossy_bytes = scratch.glossy_bytes;
    if (!scratch.nodes.empty()) page->nodes = std::move(scratch.nodes);
    if (!scratch.surfels.empty()) page->surfels = std::move(scratch.surfels);
    if (!scratch.links.empty()) page->links = std::move(scratch.links);
    return page;
  }
};

PageSetReader::PageSetReader(const std::filesystem::path& dir, std::shared_ptr<PageCache> cache,
                             PageDecorator decorate)
    : impl_(std::make_unique<Impl>(dir, std::move(cache), std::move(decorate))) {}

PageSetReader::~PageSetReader() {
  if (impl_ && impl_->cache) impl_->cache->forget(impl_->owner);
}

tree::NodeRef PageSetReader::root() const { return impl_->manifest.root; }

const tree::RegionGrid* PageSetReader::regions() const {
  return impl_->manifest.region_roots.empty() ? nullptr : &impl_->manifest.regions;
}

std::span<const tree::RegionRoot> PageSetReader::region_roots() const { return impl_->manifest.region_roots; }

tree::PagePtr PageSetReader::page(uint32_t id) const {
  if (id >= impl_->manifest.stats.page_count) {
    throw InvalidArgument(impl_->pages.path() + ": page " + std::to_string(id) +
                          " requested, the page set has " +
                          std::to_string(impl_->manifest.stats.page_count));
  }
  if (!impl_->cache) return impl_->load(id);
  return impl_->cache->get(impl_->owner, id, [this, id] { return impl_->load(id); });
}

const Manifest& PageSetReader::manifest() const { return impl_->manifest; }

const std::filesystem::path& PageSetReader::directory() const { return impl_->dir; }

}  // namespace pbgi::storage
