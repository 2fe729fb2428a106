// JSON text for the subcommands that print one JSON object (--json of
// inspect, compare, ...): strings quoted and escaped, numbers with a chosen
// precision, non-finite numbers as null (JSON has no NaN or infinity).
#pragma once

#include <string>

namespace pbgi::cli {

// `s` as a JSON string literal, quotes included; control characters as \u00XX.
std::string json_string(const std::string& s);

// `v` with `significant_digits` digits ("{:.Ng}"), or null when not finite.
std::string json_number(double v, int significant_digits);

}  // namespace pbgi::cli
