#include "client/cli/subcommand_suggestion.h"

#include <algorithm>

namespace pbgi::cli {
namespace {

// Optimal string alignment distance (Damerau-Levenshtein without repeated edits of a substring).
size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::vector<size_t>> d(a.size() + 1, std::vector<size_t>(b.size() + 1));
  for (size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[a.size()][b.size()];
}

}  // namespace

std::string suggest_subcommand(const std::string& typed, const std::vector<std::string>& known) {
  std::string best;
  size_t best_distance = ~size_t{0};
  for (const std::string& name : known) {
    const size_t limit = std::max<size_t>(1, std::max(typed.size(), name.size()) / 3);
    size_t d = edit_distance(typed, name);
    if (typed.size() >= 2 && name.rfind(typed, 0) == 0) d = 0;  // "ref" -> "reference"
    if (d <= limit && d < best_distance) {
      best = name;
      best_distance = d;
    }
  }
  return best;
}

}  // namespace pbgi::cli
