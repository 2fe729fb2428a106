// Helper process of the crash-safety test (crash_safety_test.cpp): builds
// the page set of `count` random surfels into `dir` with a small sort
// memory (so runs go to disk) and small pages, then exits 0. The test kills
// it with SIGKILL at arbitrary moments.
//   page_set_build_child DIR COUNT SEED
#include "storage/pages/page_set.h"
#include "tests/storage/pages/crash_test_options.h"
#include "tests/storage/tree/random_surfels.h"

#include <cstdio>
#include <cstdlib>
#include <exception>

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: page_set_build_child DIR COUNT SEED\n");
    return 2;
  }
  try {
    const auto surfels = pbgi::test::random_surfels(std::strtoull(argv[2], nullptr, 10),
                                                    uint32_t(std::strtoul(argv[3], nullptr, 10)));
    pbgi::storage::build_page_set(surfels, pbgi::test::crash_test_options(), "crash-test", argv[1]);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "page_set_build_child: %s\n", e.what());
    return 1;
  }
}
