// Little-endian encoding of fixed-width integers and floats. Every on-disk
// number of pbgi is little-endian, whatever the host; on little-endian hosts
// these compile to plain loads and stores.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace pbgi::storage {

namespace detail {
template <typename U>
constexpr U byteswap(U v) {
  static_assert(std::is_unsigned_v<U>);
  U r = 0;
  for (size_t i = 0; i < sizeof(U); ++i) r = U(r << 8) | U((v >> (8 * i)) & 0xff);
  return r;
}
template <typename T> struct UintOf;
template <> struct UintOf<uint8_t> { using type = uint8_t; };
template <> struct UintOf<uint16_t> { using type = uint16_t; };
template <> struct UintOf<uint32_t> { using type = uint32_t; };
template <> struct UintOf<uint64_t> { using type = uint64_t; };
template <> struct UintOf<int32_t> { using type = uint32_t; };
template <> struct UintOf<float> { using type = uint32_t; };
template <> struct UintOf<double> { using type = uint64_t; };
}  // namespace detail

// Stores v at p (unaligned) in little-endian byte order.
template <typename T>
inline void store_le(uint8_t* p, T v) {
  using U = typename detail::UintOf<T>::type;
  U u = std::bit_cast<U>(v);
  if constexpr (std::endian::native == std::endian::big) u = detail::byteswap(u);
  std::memcpy(p, &u, sizeof(U));
}

// Loads a little-endian T from p (unaligned).
template <typename T>
inline T load_le(const uint8_t* p) {
  using U = typename detail::UintOf<T>::type;
  U u;
  std::memcpy(&u, p, sizeof(U));
  if constexpr (std::endian::native == std::endian::big) u = detail::byteswap(u);
  return std::bit_cast<T>(u);
}

}  // namespace pbgi::storage
