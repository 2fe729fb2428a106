// pbgid's allocator settings, read by jemalloc at its first allocation
// (linked only into pbgid, when PBGI_JEMALLOC is on: CMakeLists.txt).
//
// Why jemalloc, and why these: under a page cache much smaller than the
// pages a load touches, every gathering thread decodes pages and the cache
// frees others, hundreds of MB a second. With glibc's malloc each thread's
// arena kept its own high-water mark, and the daemon's resident memory
// grew to 50x its --memory-budget (docs/memory-budget.md, "Allocator").
// jemalloc's size classes keep that churn from fragmenting; a background
// thread returns freed pages to the system after about a second
// (dirty_decay_ms) instead of ten, and without the intermediate "muzzy"
// state, so the daemon's resident memory follows what it holds.
extern "C" {
// NOLINTNEXTLINE(cppcoreguidelines-avoid-non-const-global-variables): jemalloc's interface
const char* malloc_conf = "background_thread:true,dirty_decay_ms:1000,muzzy_decay_ms:0";
}
