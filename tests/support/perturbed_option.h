// A value of an option's type other than the one given, for tests that
// walk options tables (each field changed in turn must show up in TOML,
// equality, the proto round trip, the build key).
#pragma once

#include "common/options/option_table.h"

#include <string>
#include <type_traits>

namespace pbgi::testing {

template <class T>
T perturbed(const T& v) {
  if constexpr (std::is_same_v<T, bool>) {
    return !v;
  } else if constexpr (options::NamedEnum<T>) {
    for (const auto& n : options::names_of<T>())
      if (n.value != v) return n.value;
    return v;
  } else if constexpr (std::is_same_v<T, std::string>) {
    return v + "x";
  } else if constexpr (std::is_floating_point_v<T>) {
    return v + T(0.125);
  } else {
    return v == 0 ? T(1) : T(v * 2);  // powers of two stay powers of two
  }
}

}  // namespace pbgi::testing
