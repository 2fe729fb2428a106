#include "client/cli/json_text.h"

#include <fmt/format.h>

#include <cmath>

namespace pbgi::cli {

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) {
      out += fmt::format("\\u{:04x}", int(c));
      continue;
    }
    out += c;
  }
  return out + "\"";
}

std::string json_number(double v, int significant_digits) {
  return std::isfinite(v) ? fmt::format("{:.{}g}", v, significant_digits) : "null";
}

}  // namespace pbgi::cli
