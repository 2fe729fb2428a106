// Sizes in config files and flags: "2GiB", "512M", "64 KiB", "1.5G", "4096".
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace pbgi {

// Parses a byte count with an optional K/M/G/T suffix (case-insensitive,
// optionally followed by "i" and/or "B"; all are powers of 1024, as memory
// budgets are). A fractional number is allowed with a suffix ("1.5G").
// Throws pbgi::InvalidArgument naming `what` and the text on a malformed,
// negative or overflowing size.
uint64_t parse_byte_size(std::string_view text, std::string_view what = "size");

// The shortest exact text for `bytes` ("2GiB", "1536MiB", "1000B").
std::string format_byte_size(uint64_t bytes);

}  // namespace pbgi
