#include "client/bench/bench_method.h"

#include "common/errors.h"

#include <set>

namespace pbgi::bench {

void MethodPlan::append(MethodPlan other) {
  for (auto& b : other.builds) builds.push_back(std::move(b));
  for (auto& c : other.configs) configs.push_back(std::move(c));
}

void MethodPlan::validate() const {
  std::set<std::string> build_names, config_names;
  for (const BuildSpec& b : builds) {
    if (b.name.empty() || !build_names.insert(b.name).second)
      throw InvalidArgument("bench: duplicate or empty build name '" + b.name + "'");
    if (!b.build) throw InvalidArgument("bench: build '" + b.name + "' has no build function");
  }
  int defaults = 0;
  for (const MethodConfig& c : configs) {
    if (c.name.empty() || !config_names.insert(c.name).second)
      throw InvalidArgument("bench: duplicate or empty configuration name '" + c.name + "'");
    if (c.method.empty()) throw InvalidArgument("bench: configuration '" + c.name + "' has no method");
    if (!c.render) throw InvalidArgument("bench: configuration '" + c.name + "' has no render function");
    if (!c.build.empty() && !build_names.count(c.build))
      throw InvalidArgument("bench: configuration '" + c.name + "' renders from unknown build '" +
                            c.build + "'");
    defaults += c.is_default ? 1 : 0;
  }
  if (defaults > 1) throw InvalidArgument("bench: more than one default configuration");
}

}  // namespace pbgi::bench
