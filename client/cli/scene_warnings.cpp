#include "client/cli/scene_warnings.h"

#include <algorithm>
#include <map>

namespace pbgi::cli {
namespace {

constexpr size_t kPrimsNamed = 3;  // per summarised line

struct Group {
  std::string message;             // without the prim
  std::vector<std::string> prims;  // empty: a warning that names no prim
};

}  // namespace

std::vector<std::string> summarize_scene_warnings(const std::vector<std::string>& warnings,
                                                  size_t max_lines) {
  // 1. Group by the message after "<prim path>: ", in order of first appearance.
  std::vector<Group> groups;
  std::map<std::string, size_t> by_message;
  for (const std::string& w : warnings) {
    const size_t colon = w.find(": ");
    if (w.empty() || w[0] != '/' || colon == std::string::npos) {
      groups.push_back({w, {}});
      continue;
    }
    const std::string message = w.substr(colon + 2);
    const auto [it, fresh] = by_message.emplace(message, groups.size());
    if (fresh) groups.push_back({message, {}});
    groups[it->second].prims.push_back(w.substr(0, colon));
  }

  // 2. One line per group, within max_lines.
  std::vector<std::string> lines;
  size_t printed = 0;
  const size_t shown = groups.size() <= max_lines ? groups.size() : std::max<size_t>(max_lines, 1) - 1;
  for (size_t i = 0; i < shown; ++i) {
    const Group& g = groups[i];
    if (g.prims.empty()) {
      lines.push_back(g.message);
    } else if (g.prims.size() == 1) {
      lines.push_back(g.prims[0] + ": " + g.message);
    } else {
      std::string named;
      for (size_t i = 0; i < g.prims.size() && i < kPrimsNamed; ++i) named += (i ? ", " : "") + g.prims[i];
      if (g.prims.size() > kPrimsNamed) named += " and " + std::to_string(g.prims.size() - kPrimsNamed) + " more";
      lines.push_back(g.message + " (" + std::to_string(g.prims.size()) + " prims: " + named + ")");
    }
    printed += std::max<size_t>(1, g.prims.size());
  }
  if (printed < warnings.size()) {
    lines.push_back(std::to_string(warnings.size() - printed) + " more warnings (pbgi status --json lists them all)");
  }
  return lines;
}

void print_scene_warnings(const v1::SceneInfo& info, std::FILE* out, const char* indent) {
  const std::vector<std::string> all(info.warnings().begin(), info.warnings().end());
  for (const std::string& line : summarize_scene_warnings(all)) {
    std::fprintf(out, "%swarning: %s\n", indent, line.c_str());
  }
}

}  // namespace pbgi::cli
