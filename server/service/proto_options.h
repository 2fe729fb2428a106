// Requests' options messages <-> the stages' options structs, through the
// structs' tables (common/options/option_table.h, proto_fields.h). A field
// the client did not set keeps the daemon's default: a field with presence
// (`optional`, a message) when absent, any other field when 0 or empty
// (proto3 cannot tell those from "not sent"); an enum when 0 (*_DEFAULT).
#pragma once

#include "common/errors.h"
#include "common/options/proto_fields.h"

#include <fmt/format.h>

#include <optional>
#include <string>
#include <type_traits>

namespace pbgi::service {

namespace pb = google::protobuf;

// Field fd of m as T; nullopt = unset (take the default). Throws
// InvalidArgument naming the field for an enum name or value this daemon
// does not know.
template <class T>
std::optional<T> get_proto(const pb::Message& m, const pb::FieldDescriptor* fd) {
  const pb::Reflection* r = m.GetReflection();
  if (fd->has_presence() && !r->HasField(m, fd)) return std::nullopt;
  const bool presence = fd->has_presence();
  auto value_or_unset = [&](auto v) -> std::optional<decltype(v)> {
    if (!presence && v == decltype(v){}) return std::nullopt;
    return v;
  };
  using C = pb::FieldDescriptor::CppType;
  const C type = fd->cpp_type();
  const std::string field = std::string(fd->containing_type()->name()) + "." + std::string(fd->name());
  if constexpr (std::is_same_v<T, bool>) {
    if (type != C::CPPTYPE_BOOL) options::proto_type_mismatch(fd);
    return value_or_unset(r->GetBool(m, fd));
  } else if constexpr (std::is_same_v<T, uint32_t>) {
    if (type != C::CPPTYPE_UINT32) options::proto_type_mismatch(fd);
    return value_or_unset(r->GetUInt32(m, fd));
  } else if constexpr (std::is_same_v<T, uint64_t>) {
    if (type != C::CPPTYPE_UINT64) options::proto_type_mismatch(fd);
    return value_or_unset(r->GetUInt64(m, fd));
  } else if constexpr (std::is_same_v<T, float>) {
    if (type != C::CPPTYPE_FLOAT) options::proto_type_mismatch(fd);
    return value_or_unset(r->GetFloat(m, fd));
  } else if constexpr (std::is_same_v<T, double>) {
    if (type != C::CPPTYPE_DOUBLE) options::proto_type_mismatch(fd);
    return value_or_unset(r->GetDouble(m, fd));
  } else if constexpr (std::is_same_v<T, std::string>) {
    if (type != C::CPPTYPE_STRING) options::proto_type_mismatch(fd);
    return value_or_unset(r->GetString(m, fd));
  } else if constexpr (options::NamedEnum<T>) {
    if (type == C::CPPTYPE_STRING) {
      const std::string name = r->GetString(m, fd);
      if (!presence && name.empty()) return std::nullopt;
      if (const auto v = options::parse_enum<T>(name)) return v;
      throw InvalidArgument(fmt::format("{}: '{}' is not one of: {}", field, name, options::enum_name_list<T>()));
    } else if (type == C::CPPTYPE_ENUM) {
      const int number = r->GetEnumValue(m, fd);
      if (number == 0) return std::nullopt;
      const pb::EnumValueDescriptor* v = fd->enum_type()->FindValueByNumber(number);
      if (v) {
        if (const auto value = options::parse_enum<T>(options::proto_enum_key(v))) return value;
      }
      throw InvalidArgument(fmt::format("{} {} is not supported by this daemon", field, number));
    } else {
      options::proto_type_mismatch(fd);
    }
  } else {
    static_assert(sizeof(T) == 0, "no proto conversion for this option type");
  }
}

// The fields of `table` set in m replace out's; the others keep out's.
template <class Table, class S>
void decode_fields(const Table& table, const pb::Message& m, S& out) {
  const pb::Descriptor* d = m.GetDescriptor();
  options::for_each_entry(table, [&](const auto& entry) {
    if constexpr (options::is_nest_v<decltype(entry)>) {
      if (entry.proto == 0) {
        decode_fields(entry.table, m, entry.get(out));
      } else {
        const pb::FieldDescriptor* fd = options::proto_field(d, entry.proto, entry.name);
        if (m.GetReflection()->HasField(m, fd)) decode_fields(entry.table, m.GetReflection()->GetMessage(m, fd), entry.get(out));
      }
    } else if (entry.spec.proto != 0) {
      using T = typename std::remove_cvref_t<decltype(entry)>::Value;
      if (const std::optional<T> v = get_proto<T>(m, options::proto_field(d, entry.spec.proto, entry.name)))
        entry.set(out, *v);
    }
  });
}

// Every field of `table` set explicitly in m (sub-messages included).
template <class Table, class S>
void encode_fields(const Table& table, const S& values, pb::Message& m) {
  const pb::Descriptor* d = m.GetDescriptor();
  options::for_each_entry(table, [&](const auto& entry) {
    if constexpr (options::is_nest_v<decltype(entry)>) {
      if (entry.proto == 0) {
        encode_fields(entry.table, entry.get(values), m);
      } else {
        const pb::FieldDescriptor* fd = options::proto_field(d, entry.proto, entry.name);
        encode_fields(entry.table, entry.get(values), *m.GetReflection()->MutableMessage(&m, fd));
      }
    } else if (entry.spec.proto != 0) {
      options::set_proto(m, options::proto_field(d, entry.spec.proto, entry.name), entry.get(values));
    }
  });
}

}  // namespace pbgi::service
