// Build options shared by the crash-safety test and its child process, so
// that the test can rebuild the reference page set in process.
#pragma once

#include "storage/tree/build_options.h"

namespace pbgi::test {

inline tree::BuildOptions crash_test_options() {
  tree::BuildOptions o;
  o.page_size = 4096;                // many pages
  o.sort_memory_bytes = 256 * 1024;  // several runs on disk
  return o;
}

}  // namespace pbgi::test
