// libFuzzer target: the daemon's TOML configuration parser. Any text must
// parse or throw pbgi::Error naming the key or position; a configuration
// that parses and validates must survive to_toml() and back unchanged
// (the daemon prints its effective configuration that way).
#include "common/errors.h"
#include "server/daemon/daemon_options.h"

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstdio>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace pbgi::daemon;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  DaemonOptions options;
  try {
    options = parse_daemon_config(text, "fuzz.toml");
    options.validate();
  } catch (const pbgi::Error&) {
    return 0;
  }
  const std::string again = to_toml(options);
  DaemonOptions reread;
  try {
    reread = parse_daemon_config(again, "to_toml");
  } catch (const pbgi::Error& e) {
    std::fprintf(stderr, "to_toml output does not parse: %s\n%s\n", e.what(), again.c_str());
    std::abort();
  }
  if (!(reread == options)) {
    std::fprintf(stderr, "to_toml round trip changed the options:\n%s\n", again.c_str());
    std::abort();
  }
  return 0;
}
