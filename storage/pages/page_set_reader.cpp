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

  // Reads page `id`'s bytes into this thread's buffer (valid until its
  // next read; a miss reads one page, and a fresh buffer each time was a
  // heap block allocated, zeroed and freed per miss).
  std::span<const uint8_t> read(uint32_t id) const {
    thread_local std::vector<uint8_t> buffer;
    const PageExtent e = manifest.pages[id];
    // What a large page grew is given back at the next smaller read.
    constexpr size_t kMaxKeptBytes = size_t(256) << 10;
    if (buffer.capacity() > kMaxKeptBytes && e.bytes <= kMaxKeptBytes) std::vector<uint8_t>().swap(buffer);
    buffer.resize(e.bytes);
    pages.pread_exact(buffer, e.offset);
    if (cache) cache->note_bytes_read(buffer.size());
    return buffer;
  }
  PageLocation where(uint32_t id) const { return {pages.path(), id, manifest.pages[id].offset}; }

  tree::PagePtr load(uint32_t id) const {
    return decode_page(read(id), where(id), manifest.page_format, *codec, manifest.stats.page_count,
                       manifest.glossy_resolution != 0, manifest.options.leaf_format);
  }

  // With a decorator: the attachment it derives from page `id`. Decoded
  // into this thread's scratch page, whose arrays the next load reuses,
  // still in the core's caches, instead of allocating and touching new
  // memory (a page cache miss decodes one page).
  std::shared_ptr<const tree::PageAttachment> load_attachment(uint32_t id) const {
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
    decode_page_into(read(id), where(id), manifest.page_format, *codec, manifest.stats.page_count,
                     manifest.glossy_resolution != 0, manifest.options.leaf_format, nullptr, scratch);
    decorate(scratch);
    if (!scratch.attachment) {
      throw Error(pages.path() + ": page " + std::to_string(id) + ": the page decorator attached nothing");
    }
    return std::move(scratch.attachment);
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

namespace {
void check_id(uint32_t id, const Manifest& m, const File& pages) {
  if (id >= m.stats.page_count) {
    throw InvalidArgument(pages.path() + ": page " + std::to_string(id) + " requested, the page set has " +
                          std::to_string(m.stats.page_count));
  }
}
}  // namespace

tree::PagePtr PageSetReader::page(uint32_t id) const {
  if (impl_->decorate) {
    // Not cached: what the cache keeps is the attachment (which checks `id`).
    auto page = std::make_shared<tree::Page>();
    page->attachment = attachment(id);
    page->id = id;
    return page;
  }
  check_id(id, impl_->manifest, impl_->pages);
  if (!impl_->cache) return impl_->load(id);
  return impl_->cache->get(impl_->owner, id, [this, id] { return impl_->load(id); });
}

std::shared_ptr<const tree::PageAttachment> PageSetReader::attachment(uint32_t id) const {
  if (!impl_->decorate) return nullptr;
  check_id(id, impl_->manifest, impl_->pages);
  if (!impl_->cache) return impl_->load_attachment(id);
  return std::static_pointer_cast<const tree::PageAttachment>(
      impl_->cache->get_value(impl_->owner, id, [this, id]() -> CachedValue {
        std::shared_ptr<const tree::PageAttachment> a = impl_->load_attachment(id);
        const uint64_t bytes = a->memory_bytes();
        return {std::move(a), bytes};
      }));
}

const Manifest& PageSetReader::manifest() const { return impl_->manifest; }

const std::filesystem::path& PageSetReader::directory() const { return impl_->dir; }

}  // namespace pbgi::storage
