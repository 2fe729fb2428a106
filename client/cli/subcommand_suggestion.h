// `pbgi rendr ...`: the subcommand the user most likely meant, so that a
// typo gets "did you mean 'render'?" instead of "A subcommand is required".
#pragma once

#include <string>
#include <vector>

namespace pbgi::cli {

// The name in `known` closest to `typed` by edit distance (insertions,
// deletions, substitutions and swaps of neighbours each cost 1), if it is
// within a third of the longer name's length (at least 1; a prefix of a
// name also matches it); "" if none is that close.
std::string suggest_subcommand(const std::string& typed, const std::vector<std::string>& known);

}  // namespace pbgi::cli
