// Every page of a page set read and decoded once, with where its parts lie
// (storage/pages/page_encoding.h PageParts): the benchmarks' breakdowns of
// a set's bytes by part.
#pragma once

#include "common/errors.h"
#include "storage/codecs/payload_codec.h"
#include "storage/pages/page_encoding.h"
#include "storage/pages/page_set.h"

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace pbgi::test {

// Calls f(parts, page_bytes) for each page of the set in `dir` (whose
// manifest is `m`), in id order. Throws IoError for a page it cannot read,
// CorruptionError for one that does not decode.
template <typename F>
void for_each_page_parts(const std::filesystem::path& dir, const storage::Manifest& m, F&& f) {
  const std::filesystem::path file = dir / storage::kPagesFileName;
  std::ifstream in(file, std::ios::binary);
  const auto codec = storage::make_payload_codec(m.codec, m.codec_state, dir.string());
  std::vector<uint8_t> page;
  for (uint32_t id = 0; id < m.pages.size(); ++id) {
    const storage::PageExtent e = m.pages[id];
    page.resize(e.bytes);
    in.seekg(std::streamoff(e.offset));
    in.read(reinterpret_cast<char*>(page.data()), std::streamsize(page.size()));
    if (!in) throw IoError(file.string() + ": cannot read page " + std::to_string(id));
    storage::PageParts parts;
    (void)storage::decode_page(page, {file.string(), id, e.offset}, m.page_format, *codec, uint32_t(m.pages.size()),
                               m.glossy_resolution != 0, m.options.leaf_format, &parts);
    f(parts, page.size());
  }
}

}  // namespace pbgi::test
