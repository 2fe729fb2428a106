// Multiple bounces out of core: the page set of bounce b is built from the
// page set of direct light (bounce 1) and the page set of bounce b - 1,
// page by page, without holding the surfels in memory.
//
// Every surfel of the direct set is a receiver: its indirect irradiance is
// gathered from the tree of bounce b - 1 and its outgoing radiance becomes
// direct + albedo/pi E (server/gather/surfel_bounce.h). The receivers are
// always read from the *direct* set, whose radiance is the direct term the
// new radiance is built on; the sets of later bounces only serve gathers.
// Surfels go to a PageSetBuilder in the direct set's page order (Morton
// order, so a gather batch is a compact patch), which sorts them again
// within its memory bound.
//
// Each bounce's set is content-addressed like any page set (its key holds
// the bounce count and the bounce gather options), so a build for 3 bounces
// leaves the 2-bounce set behind, reused by a later open asking for 2.
//
// Glossy senders: stored surfels have no lobe (storage/tree/surfel.h), so
// `glossy.restore` gives each batch its lobes back before it goes to the
// builder, and `glossy.shader` lights them for the pages' wavelet cube maps
// as the direct set's build does (direct light only: docs/gather.md,
// section 9b). The diffuse part of a glossy surfel gathers like any.
#pragma once

#include "server/gather/surfel_bounce.h"
#include "storage/pages/page_set.h"

#include <Imath/ImathBox.h>

#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>

namespace pbgi {

// How a bounce's set gets its glossy senders' radiance; both empty: it
// stores none.
struct BounceGlossy {
  const storage::GlossyShader* shader = nullptr;   // must outlive the build
  std::function<void(std::span<Surfel>)> restore;  // sets Surfel::gloss
};

// Builds the page set of one more bounce into `dir` (published atomically,
// as PageSetBuilder does). `direct` is the bounce-1 set, `previous` the set
// to gather from (equal to `direct` for bounce 2). `progress` gets
// fractions in [0, 1] on this thread; `cancelled` is polled between
// gather batches and merge percents (Cancelled). What the build stages is
// charged to `staging_quota` (null: no limit; PageSetBuilder::
// set_staging_quota). `memory_hook` (may be empty) is told the bytes of
// the page tables the build holds (its own as it grows, and its reader's
// copy of the direct set's), before each growth (PageSetBuilder::
// set_memory_hook). Throws what the reader, the gather, the builder and
// the hook throw (nothing is published then).
storage::Manifest build_bounce_page_set(const storage::PageSetReader& direct, const tree::TreeSource& previous,
                                        const BounceOptions& options, const tree::BuildOptions& tree_options,
                                        const std::string& build_key, const std::filesystem::path& dir,
                                        const Imath::Box3f& bounds, const BounceGlossy& glossy = {},
                                        const std::function<void(float)>& progress = {},
                                        const std::function<bool()>& cancelled = {},
                                        std::shared_ptr<storage::StagingQuota> staging_quota = {},
                                        const std::function<void(uint64_t)>& memory_hook = {});

}  // namespace pbgi
