// Parses a command line into one of the CLI's shared flag structs the way
// `pbgi` does (CLI11 through the struct's add_to), for the flag tests.
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace pbgi::cli::testing {

template <typename Args>
Args parse_flags(std::vector<std::string> argv) {
  CLI::App app;
  Args args;
  args.add_to(&app);
  argv.insert(argv.begin(), "pbgi");
  std::vector<const char*> c;
  for (const auto& a : argv) c.push_back(a.c_str());
  app.parse(int(c.size()), c.data());
  return args;
}

}  // namespace pbgi::cli::testing
