// An option's value as text for keys (the page set's build key, the scene
// registry's key): numbers as the shortest text that reads back to the
// same value, booleans as true/false, enums by name, strings as they are.
#pragma once

#include "common/options/option_table.h"

#include <fmt/format.h>

#include <string>
#include <type_traits>

namespace pbgi::options {

template <class T>
std::string option_text(const T& value) {
  if constexpr (NamedEnum<T>) {
    return std::string(enum_name(value));
  } else if constexpr (std::is_same_v<T, bool>) {
    return value ? "true" : "false";
  } else {
    return fmt::format("{}", value);
  }
}

}  // namespace pbgi::options
