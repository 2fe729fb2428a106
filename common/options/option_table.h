// Descriptor tables of options structs: each configurable field is
// described once, beside its struct, and the daemon's TOML config, the gRPC
// conversion, the CLI flags, equality and the page set's build key are all
// derived from that one description (the model: RocksDB's OptionTypeInfo
// tables in options/cf_options.cc).
//
// A table is a std::tuple of entries over one struct S:
//   field<&S::member>("name", {...})        a value: bool, uint32_t,
//       uint64_t, float, double, std::string or a named enum (below);
//       a path of members (&S::sub, &Sub::x) reaches into a sub-struct.
//   custom<S, T>("name", get, set, {...})    a value stored differently
//       (fog's grey albedo: one float, an Imath::C3f in the struct).
//   nest<&S::sub>(kSubTable)                 the sub-struct's fields, as if
//       they were S's (same TOML section, same proto message);
//   nest<&S::sub>(kSubTable, {"name", n})    the sub-struct as its own proto
//       message, field n of S's message (and its own TOML section).
// The entry's name is the TOML key and the proto field's name (a test
// checks both); FieldSpec says the rest (proto field number, CLI flag,
// build-key membership).
//
// Enums: an enum E is an option value when a function
//   constexpr std::span<const EnumName<E>> enum_names(E)
// is declared beside it (found by argument-dependent lookup). Its names
// are the only spelling of its values in config files, flags and requests.
//
// How to add an option (a field of GatherOptions, say):
//   1. the field with its documented default in the struct;
//   2. one entry in the struct's table (next to the struct): its name,
//      proto field number, CLI flag and help, build-key membership (only
//      for what a page set is built from, KeyMember below);
//   3. the proto field in proto/pbgi/v1/pbgi.proto, named as the entry
//      (scalars whose 0 is a valid value: `optional`);
//   4. a test of what the option does (tests/common/options checks that
//      the entry, the proto field and the flag agree).
// The TOML key, `pbgid --print-config`, the request decoding, `pbgi`'s
// flag and equality follow from the entry. A range check belongs in the
// struct's validate(); config/pbgid.toml documents the key for users.
//
// Thread-safety: tables are constexpr data; the functions are pure.
#pragma once

#include <array>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <vector>

namespace pbgi::options {

// ---- enum names ----

template <class E>
struct EnumName {
  E value;
  std::string_view name;
};

template <class E>
concept NamedEnum = std::is_enum_v<E> && requires(E e) {
  { enum_names(e) } -> std::convertible_to<std::span<const EnumName<E>>>;
};

template <NamedEnum E>
constexpr std::span<const EnumName<E>> names_of() {
  return enum_names(E{});
}

// The value's name; "" for a value without one (a cast from a bad number).
template <NamedEnum E>
constexpr std::string_view enum_name(E value) {
  for (const EnumName<E>& n : names_of<E>())
    if (n.value == value) return n.name;
  return {};
}

// The value named `name`; nullopt for any other text.
template <NamedEnum E>
constexpr std::optional<E> parse_enum(std::string_view name) {
  for (const EnumName<E>& n : names_of<E>())
    if (n.name == name) return n.value;
  return std::nullopt;
}

// "a, b, c" (or with another separator: "a or b"), for error messages.
template <NamedEnum E>
std::string enum_name_list(std::string_view separator = ", ") {
  std::string out;
  for (const EnumName<E>& n : names_of<E>()) {
    if (!out.empty()) out += separator;
    out += n.name;
  }
  return out;
}

// ---- what an entry says besides its name ----

// Whether a field changes the bytes of the page set built with it, and so
// belongs in the build key (server/engine/build_key.cpp).
enum class KeyMember : uint8_t {
  // Never changes the stored bytes (request-time options, speed and
  // memory knobs, options that reach the page set through the scene's
  // content hash).
  kNo,
  // Part of the frozen v1 text written in build_key.cpp (options that
  // existed when the table was introduced; their text never changes, so
  // that cached page sets keep their keys).
  kFrozen,
  // Appended to the key as "|name=value" when the value differs from the
  // struct's default, so adding such an option keeps every existing key.
  kIfNotDefault,
};

// A CLI11 validator, described without CLI11 (client/cli/option_flags.h
// builds it with the field's own type, so help text shows "UINT"/"FLOAT").
struct Check {
  enum class Kind : uint8_t { kNone, kRange, kNonNegative, kPositive, kOneOf };
  Kind kind = Kind::kNone;
  double lo = 0, hi = 0;
  std::array<double, 8> one_of{};
  uint8_t one_of_count = 0;
};
constexpr Check range(double lo, double hi) { return {Check::Kind::kRange, lo, hi}; }
constexpr Check non_negative() { return {Check::Kind::kNonNegative}; }
constexpr Check positive() { return {Check::Kind::kPositive}; }
constexpr Check one_of(std::initializer_list<double> values) {
  Check c{Check::Kind::kOneOf};
  for (double v : values) c.one_of[c.one_of_count++] = v;
  return c;
}

// A flag spelling of an enum value that is not its name ("sh" for
// "derived"); `to` empty: the spelling is refused with `error`.
struct FlagAlias {
  std::string_view from, to, error;
};

// The `pbgi` command-line flag of a field (render and tile commands).
struct Flag {
  enum class Kind : uint8_t {
    kValue,      // --name VALUE
    kSetsTrue,   // --name alone sets the field to true
    kSetsFalse,  // --name alone sets the field to false (--hide-dome)
  };
  std::string_view name;  // "--mb-res"; empty: no flag
  std::string_view help;  // as printed by --help, defaults in [brackets]
  Check check{};          // (an enum's flag is checked against its names)
  Kind kind = Kind::kValue;
  // An enum's other spellings; with aliases the flag takes any text and
  // the daemon refuses an unknown name.
  std::span<const FlagAlias> aliases{};
};

struct FieldSpec {
  int proto = 0;  // field number in the struct's proto message; 0: not on the wire
  Flag flag{};
  KeyMember key = KeyMember::kNo;
};

// ---- entries ----

template <class S, class T>
struct Field {
  using Struct = S;
  using Value = T;
  std::string_view name;
  T (*get)(const S&);
  void (*set)(S&, const T&);
  FieldSpec spec;
};

template <class S, class Sub, class Table>
struct Nest {
  using Struct = S;
  using SubStruct = Sub;
  Sub& (*ref)(S&);
  Table table;
  // Sub-message: its name (TOML section, proto field) and field number;
  // number 0 = flattened into S.
  std::string_view name;
  int proto = 0;
  const Sub& get(const S& s) const { return ref(const_cast<S&>(s)); }
  Sub& get(S& s) const { return ref(s); }
};

struct SubMessage {
  std::string_view name;
  int proto = 0;
};

namespace detail {

template <class M>
struct MemberTraits;
template <class C, class T>
struct MemberTraits<T C::*> {
  using Class = C;
  using Type = T;
};

template <auto First, auto... Rest>
struct PathTraits {
  using Class = typename MemberTraits<decltype(First)>::Class;
  using Type = typename PathTraits<Rest...>::Type;
};
template <auto Last>
struct PathTraits<Last> {
  using Class = typename MemberTraits<decltype(Last)>::Class;
  using Type = typename MemberTraits<decltype(Last)>::Type;
};

template <auto First, auto... Rest, class Obj>
constexpr auto& follow(Obj& obj) {
  if constexpr (sizeof...(Rest) == 0) {
    return obj.*First;
  } else {
    return follow<Rest...>(obj.*First);
  }
}

template <class S, class T, auto... Path>
T get_path(const S& s) {
  return follow<Path...>(s);
}
template <class S, class T, auto... Path>
void set_path(S& s, const T& v) {
  follow<Path...>(s) = v;
}
template <class S, class Sub, auto... Path>
Sub& ref_path(S& s) {
  return follow<Path...>(s);
}

template <class E>
struct IsField : std::false_type {};
template <class S, class T>
struct IsField<Field<S, T>> : std::true_type {};
template <class E>
struct IsNest : std::false_type {};
template <class S, class Sub, class Table>
struct IsNest<Nest<S, Sub, Table>> : std::true_type {};

}  // namespace detail

template <class E>
inline constexpr bool is_field_v = detail::IsField<std::remove_cvref_t<E>>::value;
template <class E>
inline constexpr bool is_nest_v = detail::IsNest<std::remove_cvref_t<E>>::value;

// A member (or a path of members) of S as an option.
template <auto... Path>
constexpr auto field(std::string_view name, FieldSpec spec = {}) {
  using S = typename detail::PathTraits<Path...>::Class;
  using T = typename detail::PathTraits<Path...>::Type;
  return Field<S, T>{name, &detail::get_path<S, T, Path...>, &detail::set_path<S, T, Path...>, spec};
}

// A value S stores in another form (get/set: captureless lambdas).
template <class S, class T>
constexpr auto custom(std::string_view name, T (*get)(const S&), void (*set)(S&, const T&),
                      FieldSpec spec = {}) {
  return Field<S, T>{name, get, set, spec};
}

template <auto... Path, class Table>
constexpr auto nest(const Table& table, SubMessage message = {}) {
  using S = typename detail::PathTraits<Path...>::Class;
  using Sub = typename detail::PathTraits<Path...>::Type;
  return Nest<S, Sub, Table>{&detail::ref_path<S, Sub, Path...>, table, message.name, message.proto};
}

template <class... Entries>
constexpr auto table(Entries... entries) {
  return std::tuple<Entries...>{entries...};
}

// ---- walking a table ----

// fn(entry) for each entry (fields and nests, not recursing).
template <class Table, class Fn>
constexpr void for_each_entry(const Table& table, Fn&& fn) {
  std::apply([&](const auto&... entry) { (fn(entry), ...); }, table);
}

// fn(field, objects...) for every field, recursing into every nest;
// objects are structs the table describes (the field's get/set apply).
template <class Table, class Fn, class... Objects>
void for_each_value(const Table& table, Fn&& fn, Objects&... objects) {
  for_each_entry(table, [&](const auto& entry) {
    if constexpr (is_nest_v<decltype(entry)>) {
      for_each_value(entry.table, fn, entry.get(objects)...);
    } else {
      fn(entry, objects...);
    }
  });
}

// fn(field) for every field, recursing into every nest.
template <class Table, class Fn>
constexpr void for_each_field(const Table& table, Fn&& fn) {
  for_each_entry(table, [&](const auto& entry) {
    if constexpr (is_nest_v<decltype(entry)>) {
      for_each_field(entry.table, fn);
    } else {
      fn(entry);
    }
  });
}

// Every field equal: the options struct's operator== is this over its
// table (fields outside the table are not options and are not compared).
template <class Table, class S>
bool equal(const Table& table, const S& a, const S& b) {
  bool same = true;
  for_each_value(
      table, [&](const auto& f, const auto& x, const auto& y) { same = same && f.get(x) == f.get(y); },
      a, b);
  return same;
}

}  // namespace pbgi::options
