// Every flag of the options tables parses and reaches the request: one
// flag at a time, with a value its check accepts, sets its message field.
#include "client/cli/build_flags.h"
#include "client/cli/gather_flags.h"
#include "server/engine/open_options.h"
#include "server/render/render_options.h"
#include "tests/client/cli/parse_flags.h"

#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

namespace pbgi::cli {
namespace {

// A value the flag's check accepts and that is not the proto's "unset".
template <class T>
std::vector<std::string> arguments(const options::Flag& flag) {
  std::vector<std::string> args{std::string(flag.name)};
  if (flag.kind != options::Flag::Kind::kValue) return args;
  if constexpr (options::NamedEnum<T>) {
    args.emplace_back(options::names_of<T>().front().name);
  } else if constexpr (std::is_same_v<T, std::string>) {
    args.emplace_back("x");
  } else if constexpr (std::is_same_v<T, bool>) {
    args.emplace_back("false");
  } else if (flag.check.kind == options::Check::Kind::kRange) {
    args.push_back(std::to_string(T(flag.check.hi)));
  } else if (flag.check.kind == options::Check::Kind::kOneOf) {
    args.push_back(std::to_string(T(flag.check.one_of[0])));
  } else {
    args.emplace_back("2");
  }
  return args;
}

template <class Args, class Table>
void expect_every_flag_reaches_the_request(const Table& table, std::set<std::string>& names) {
  int checked = 0;
  options::for_each_field(table, [&](const auto& f) {
    if (f.spec.flag.name.empty()) return;
    using T = typename std::remove_cvref_t<decltype(f)>::Value;
    EXPECT_TRUE(names.insert(std::string(f.spec.flag.name)).second) << f.spec.flag.name << " twice";
    const std::vector<std::string> args = arguments<T>(f.spec.flag);
    const auto message = testing::parse_flags<Args>(args).to_proto();
    EXPECT_GT(message.ByteSizeLong(), 0u) << f.spec.flag.name << " set nothing";
    EXPECT_EQ(testing::parse_flags<Args>({}).to_proto().ByteSizeLong(), 0u);
    ++checked;
  });
  EXPECT_GT(checked, 5);
}

TEST(OptionFlags, EveryFlagReachesTheRequestAndNamesAreUnique) {
  std::set<std::string> names;  // render and tile take both sets of flags
  expect_every_flag_reaches_the_request<GatherArgs>(kRenderOptionTable, names);
  expect_every_flag_reaches_the_request<BuildArgs>(kOpenOptionTable, names);
}

}  // namespace
}  // namespace pbgi::cli
