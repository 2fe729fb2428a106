// The daemon's config file, read and written through options tables
// (common/options/option_table.h): a section is a table over a struct,
// each field one key of the TOML type its C++ type maps to (integers,
// floats, booleans, strings; enums as their names; lists of strings).
// Header-only templates over the tables; used by daemon_options.cpp.
#pragma once

#include "common/errors.h"
#include "common/options/option_table.h"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <cstdint>
#include <cstdlib>
#include <limits>
#include <ostream>
#include <set>
#include <string>
#include <type_traits>
#include <vector>

namespace pbgi::daemon {

// Reads the keys of one TOML table into fields, remembering which keys it
// consumed so that whatever is left over can be reported as unknown.
class TableReader {
 public:
  TableReader(const toml::table& table, std::string prefix, const std::string& source)
      : table_(table), prefix_(std::move(prefix)), source_(source) {}

  void read(const char* key, std::string& out) {
    if (const toml::node* node = find(key)) {
      if (!node->is_string()) throw type_error(key, "a string");
      out = node->as_string()->get();
    }
  }
  void read(const char* key, bool& out) {
    if (const toml::node* node = find(key)) {
      if (!node->is_boolean()) throw type_error(key, "true or false");
      out = node->as_boolean()->get();
    }
  }
  template <class T>
    requires std::is_integral_v<T> && std::is_unsigned_v<T> && (!std::is_same_v<T, bool>)
  void read(const char* key, T& out) {
    if (const toml::node* node = find(key)) {
      if (!node->is_integer()) throw type_error(key, "an integer");
      const int64_t v = node->as_integer()->get();
      if (v < 0 || static_cast<uint64_t>(v) > std::numeric_limits<T>::max()) {
        throw InvalidArgument(fmt::format("config '{}': key '{}' = {} is out of range 0..{}",
                                          source_, name(key), v, std::numeric_limits<T>::max()));
      }
      out = static_cast<T>(v);
    }
  }
  template <class T>
    requires std::is_floating_point_v<T>
  void read(const char* key, T& out) {
    if (const toml::node* node = find(key)) {
      if (node->is_floating_point()) {
        out = static_cast<T>(node->as_floating_point()->get());
      } else if (node->is_integer()) {
        out = static_cast<T>(node->as_integer()->get());
      } else {
        throw type_error(key, "a number");
      }
    }
  }
  void read(const char* key, std::vector<std::string>& out) {
    if (const toml::node* node = find(key)) {
      if (!node->is_array()) throw type_error(key, "an array of strings");
      std::vector<std::string> values;
      for (const toml::node& element : *node->as_array()) {
        if (!element.is_string()) throw type_error(key, "an array of strings");
        values.push_back(element.as_string()->get());
      }
      out = std::move(values);
    }
  }
  // An enum, as one of its names.
  template <options::NamedEnum E>
  void read(const char* key, E& out) {
    std::string text(options::enum_name(out));
    read(key, text);
    const auto value = options::parse_enum<E>(text);
    if (!value) {
      throw InvalidArgument(fmt::format("config '{}': key '{}' = '{}' is not one of: {}", source_,
                                        name(key), text, options::enum_name_list<E>()));
    }
    out = *value;
  }
  // A sub-table, or nullptr if absent.
  const toml::table* table(const char* key) {
    const toml::node* node = find(key);
    if (!node) return nullptr;
    if (!node->is_table()) throw type_error(key, "a table");
    return node->as_table();
  }
  std::string name(const char* key) const { return prefix_.empty() ? key : prefix_ + "." + key; }

  // Throws naming the first key that no read() asked for.
  void reject_unknown() const {
    for (const auto& [key, node] : table_) {
      if (!seen_.count(std::string(key.str()))) {
        throw InvalidArgument(fmt::format("config '{}': unknown key '{}' (line {})", source_,
                                          name(std::string(key.str()).c_str()),
                                          node.source().begin.line));
      }
    }
  }

 private:
  const toml::node* find(const char* key) {
    seen_.insert(key);
    return table_.get(key);
  }
  InvalidArgument type_error(const char* key, const char* expected) const {
    return InvalidArgument(
        fmt::format("config '{}': key '{}' must be {}", source_, name(key), expected));
  }

  const toml::table& table_;
  std::string prefix_;
  const std::string& source_;
  std::set<std::string> seen_;
};

// Reads every field of `table` present in the TOML table into `out`;
// sub-message nests (their own section) are left to the caller.
template <class Table, class S>
void read_fields(TableReader& reader, const Table& table, S& out) {
  options::for_each_entry(table, [&](const auto& entry) {
    if constexpr (options::is_nest_v<decltype(entry)>) {
      if (entry.proto == 0) read_fields(reader, entry.table, entry.get(out));
    } else {
      auto value = entry.get(out);
      reader.read(std::string(entry.name).c_str(), value);
      entry.set(out, value);
    }
  });
}

// Writes `key = value` lines. Written by hand rather than through toml++'s
// formatter, which prints floats with 17 digits (0.029999999999999999) or
// only 6: here a float prints as the shortest text that reads back to the
// same float.
class TomlWriter {
 public:
  explicit TomlWriter(std::ostream& out) : out_(out) {}

  void write(std::string_view key, const std::string& v) {
    out_ << key << " = " << toml::value<std::string>(v) << '\n';
  }
  void write(std::string_view key, const std::vector<std::string>& v) {
    toml::array array;
    for (const std::string& s : v) array.push_back(s);
    out_ << key << " = " << array << '\n';
  }
  void write(std::string_view key, bool v) { out_ << key << " = " << (v ? "true" : "false") << '\n'; }
  template <class T>
    requires std::is_integral_v<T> && std::is_unsigned_v<T> && (!std::is_same_v<T, bool>)
  void write(std::string_view key, T v) {
    out_ << key << " = " << uint64_t(v) << '\n';
  }
  void write(std::string_view key, double v) {
    std::string text = fmt::format("{}", v);
    if (text.find_first_of(".eEn") == std::string::npos) text += ".0";  // TOML float syntax
    out_ << key << " = " << text << '\n';
  }
  // TOML floats are doubles: write a float as the double with the same
  // shortest text (0.03f -> 0.03, not 0.029999999329447746).
  void write(std::string_view key, float v) {
    write(key, std::strtod(fmt::format("{}", v).c_str(), nullptr));
  }
  template <options::NamedEnum E>
  void write(std::string_view key, E v) {
    write(key, std::string(options::enum_name(v)));
  }

 private:
  std::ostream& out_;
};

// Writes every field of `table` (sub-message nests excepted, as read_fields).
template <class Table, class S>
void write_fields(TomlWriter& writer, const Table& table, const S& values) {
  options::for_each_entry(table, [&](const auto& entry) {
    if constexpr (options::is_nest_v<decltype(entry)>) {
      if (entry.proto == 0) write_fields(writer, entry.table, entry.get(values));
    } else {
      writer.write(entry.name, entry.get(values));
    }
  });
}

}  // namespace pbgi::daemon
