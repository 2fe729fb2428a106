#include "common/byte_size.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <cctype>
#include <charconv>
#include <cmath>

namespace pbgi {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

}  // namespace

uint64_t parse_byte_size(std::string_view text, std::string_view what) {
  auto fail = [&](const char* why) {
    return InvalidArgument(fmt::format("{} '{}' is not a valid size ({}); expected e.g. 512MiB, "
                                       "2G, 4096",
                                       what, text, why));
  };
  std::string_view s = trim(text);

  // Number part: digits with at most one '.'.
  size_t end = 0;
  bool seen_dot = false;
  while (end < s.size() && (std::isdigit(static_cast<unsigned char>(s[end])) ||
                            (s[end] == '.' && !seen_dot))) {
    seen_dot |= s[end] == '.';
    ++end;
  }
  const std::string_view number = s.substr(0, end);
  if (number.empty() || number == ".") throw fail("no number");
  std::string_view suffix = trim(s.substr(end));

  // Suffix: [KMGT][i][B] or [B] or nothing.
  int shift = 0;
  if (!suffix.empty()) {
    switch (std::toupper(static_cast<unsigned char>(suffix.front()))) {
      case 'K': shift = 10; break;
      case 'M': shift = 20; break;
      case 'G': shift = 30; break;
      case 'T': shift = 40; break;
      case 'B': break;
      default: throw fail("unknown unit");
    }
    if (shift != 0) {
      suffix.remove_prefix(1);
      if (!suffix.empty() && (suffix.front() == 'i' || suffix.front() == 'I')) suffix.remove_prefix(1);
    }
    if (!suffix.empty() && (suffix.front() == 'B' || suffix.front() == 'b')) suffix.remove_prefix(1);
    if (!suffix.empty()) throw fail("unknown unit");
  }

  if (!seen_dot) {
    uint64_t value = 0;
    auto [ptr, ec] = std::from_chars(number.data(), number.data() + number.size(), value);
    if (ec != std::errc() || ptr != number.data() + number.size()) throw fail("too large");
    if (shift > 0 && value > (UINT64_MAX >> shift)) throw fail("too large");
    return value << shift;
  }
  if (shift == 0) throw fail("a fraction of a byte");
  double value = 0;
  auto [ptr, ec] = std::from_chars(number.data(), number.data() + number.size(), value);
  if (ec != std::errc() || ptr != number.data() + number.size()) throw fail("bad number");
  const double bytes = std::ldexp(value, shift);
  if (!(bytes < 9.0e18)) throw fail("too large");  // llround range
  return static_cast<uint64_t>(std::llround(bytes));
}

std::string format_byte_size(uint64_t bytes) {
  static constexpr const char* kUnits[] = {"TiB", "GiB", "MiB", "KiB"};
  static constexpr int kShifts[] = {40, 30, 20, 10};
  if (bytes != 0) {
    for (int i = 0; i < 4; ++i) {
      const uint64_t unit = uint64_t(1) << kShifts[i];
      if (bytes % unit == 0) return fmt::format("{}{}", bytes / unit, kUnits[i]);
    }
  }
  return fmt::format("{}B", bytes);
}

}  // namespace pbgi
