// `pbgi` flags from options tables (common/options/option_table.h): each
// entry with a Flag becomes one CLI11 option of the entry's type (the
// table's check as its validator; an enum checked against its names), and
// a flag given on the command line sets the entry's field of the request
// message (common/options/proto_fields.h). Flags not given leave their
// fields unset: the daemon's defaults.
#pragma once

#include "common/options/option_table.h"
#include "common/options/proto_fields.h"

#include <CLI/CLI.hpp>

#include <functional>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

namespace pbgi::cli {

class OptionFlags {
 public:
  // Adds the flags of `table`, whose proto numbers are fields of `message`.
  template <class Table>
  void add(CLI::App* cmd, const Table& table, const google::protobuf::Descriptor* message) {
    add_entries(cmd, table, Path{message, {}});
  }

  // Sets the fields of the flags given, in the order given (a repeated
  // flag: the last wins). Throws InvalidArgument for a refused alias.
  void apply(google::protobuf::Message& message) const {
    for (const auto& set : *given_) set(message);
  }

 private:
  using Setter = std::function<void(google::protobuf::Message&)>;
  // Where a table's fields are: its message type, and the sub-message
  // fields leading to it from the top message.
  struct Path {
    const google::protobuf::Descriptor* type;
    std::vector<const google::protobuf::FieldDescriptor*> messages;
    google::protobuf::Message& resolve(google::protobuf::Message& top) const {
      google::protobuf::Message* m = &top;
      for (const auto* fd : messages) m = m->GetReflection()->MutableMessage(m, fd);
      return *m;
    }
  };

  template <class Table>
  void add_entries(CLI::App* cmd, const Table& table, const Path& path);
  template <class T>
  void add_field(CLI::App* cmd, const options::Flag& flag, const Path& path,
                 const google::protobuf::FieldDescriptor* fd);

  std::shared_ptr<std::vector<Setter>> given_ = std::make_shared<std::vector<Setter>>();
};

// Throws pbgi::InvalidArgument with the alias's message.
[[noreturn]] void refuse_flag_alias(const options::FlagAlias& alias);

template <class Table>
void OptionFlags::add_entries(CLI::App* cmd, const Table& table, const Path& path) {
  options::for_each_entry(table, [&](const auto& entry) {
    if constexpr (options::is_nest_v<decltype(entry)>) {
      if (entry.proto == 0) {
        add_entries(cmd, entry.table, path);
      } else {
        const auto* fd = options::proto_field(path.type, entry.proto, entry.name);
        Path sub{fd->message_type(), path.messages};
        sub.messages.push_back(fd);
        add_entries(cmd, entry.table, sub);
      }
    } else if (!entry.spec.flag.name.empty()) {
      using T = typename std::remove_cvref_t<decltype(entry)>::Value;
      add_field<T>(cmd, entry.spec.flag, path, options::proto_field(path.type, entry.spec.proto, entry.name));
    }
  });
}

namespace detail {

template <class T>
CLI::Validator validator(const options::Check& check) {
  using K = options::Check::Kind;
  switch (check.kind) {
    case K::kRange: return CLI::Range(T(check.lo), T(check.hi));
    case K::kNonNegative: return CLI::NonNegativeNumber;
    case K::kPositive: return CLI::PositiveNumber;
    case K::kOneOf: {
      std::vector<T> values;
      for (uint8_t i = 0; i < check.one_of_count; ++i) values.push_back(T(check.one_of[i]));
      return CLI::IsMember(values);
    }
    case K::kNone: break;
  }
  return CLI::Validator();
}

}  // namespace detail

template <class T>
void OptionFlags::add_field(CLI::App* cmd, const options::Flag& flag, const Path& path,
                            const google::protobuf::FieldDescriptor* fd) {
  const std::string name(flag.name), help(flag.help);
  auto given = given_;
  if constexpr (std::is_same_v<T, bool>) {
    if (flag.kind != options::Flag::Kind::kValue) {
      const bool value = flag.kind == options::Flag::Kind::kSetsTrue;
      cmd->add_flag_callback(name, [given, path, fd, value] {
        given->push_back([path, fd, value](auto& m) { options::set_proto(path.resolve(m), fd, value); });
      }, help);
      return;
    }
  }
  if constexpr (options::NamedEnum<T>) {
    // Read as text: a name, or one of the aliases (checked when the request
    // is made, so that --help and parsing never throw).
    std::vector<std::string> names;
    for (const auto& n : options::names_of<T>()) names.emplace_back(n.name);
    const std::span<const options::FlagAlias> aliases = flag.aliases;
    CLI::Option* option = cmd->add_option_function<std::string>(
        name,
        [given, path, fd, aliases](const std::string& text) {
          given->push_back([path, fd, aliases, text](auto& m) {
            std::string value = text;
            for (const options::FlagAlias& a : aliases) {
              if (a.from != text) continue;
              if (a.to.empty()) refuse_flag_alias(a);
              value = std::string(a.to);
            }
            if (const auto e = options::parse_enum<T>(value)) {
              options::set_proto(path.resolve(m), fd, *e);
            } else {
              // Unchecked (aliased) text goes as written: the daemon refuses it by name.
              options::set_proto(path.resolve(m), fd, value);
            }
          });
        },
        help);
    if (aliases.empty()) option->check(CLI::IsMember(names));
  } else {
    CLI::Option* option = cmd->add_option_function<T>(
        name,
        [given, path, fd](const T& value) {
          given->push_back([path, fd, value](auto& m) { options::set_proto(path.resolve(m), fd, value); });
        },
        help);
    if constexpr (!std::is_same_v<T, std::string>) {
      if (flag.check.kind != options::Check::Kind::kNone) option->check(detail::validator<T>(flag.check));
    }
  }
}

}  // namespace pbgi::cli
