// The content address of a page set: a hash of everything its bytes depend
// on (the scene's content, surfel and tree options, the page format). Two
// opens with the same key share one page set on disk.
#pragma once

#include "server/engine/open_options.h"

#include <string>

namespace pbgi {

std::string page_set_build_key(const std::string& scene_content_hash, const OpenOptions& options);

}  // namespace pbgi
