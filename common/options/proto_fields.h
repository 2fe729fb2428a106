// Options tables (option_table.h) and protobuf messages: an entry's proto
// field is found by its number through the message's descriptor, and set
// through reflection.
//
// Why reflection and not accessors registered per field: a per-field
// accessor list would be one more place to edit for each option (the
// service's codec was exactly that list). With the number in the entry,
// the table stays free of generated code (the stages do not depend on the
// wire contract), and a test (tests/common/options) checks every entry
// against the descriptor: the field exists, has the entry's name and a
// type the entry's C++ type converts to exactly. A mismatch is a
// programming error: std::logic_error, never a silent conversion.
//
// Enums travel as strings (their names) or as proto enums; a proto enum
// value maps to the C++ value of the same name, lower case, without the
// enum type's name as a prefix (PBGI -> "pbgi", INTERPOLATION_OFF -> "off"
// in enum Interpolation); value 0 means "unset".
#pragma once

#include "common/options/option_table.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>

#include <cctype>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>

namespace pbgi::options {

namespace pb = google::protobuf;

// Field `number` of message type `d`, which must be named `name`.
inline const pb::FieldDescriptor* proto_field(const pb::Descriptor* d, int number, std::string_view name) {
  const pb::FieldDescriptor* fd = d->FindFieldByNumber(number);
  if (!fd || fd->name() != name) {
    throw std::logic_error("options table: " + std::string(d->name()) + " has no field " +
                           std::to_string(number) + " named '" + std::string(name) + "'");
  }
  return fd;
}

// The C++ enum name a proto enum value stands for ("off" for
// INTERPOLATION_OFF of enum Interpolation).
inline std::string proto_enum_key(const pb::EnumValueDescriptor* v) {
  std::string prefix;
  for (char c : std::string(v->type()->name())) prefix += char(std::toupper(static_cast<unsigned char>(c)));
  prefix += '_';
  std::string name(v->name());
  if (name.compare(0, prefix.size(), prefix) == 0) name.erase(0, prefix.size());
  for (char& c : name) c = char(std::tolower(static_cast<unsigned char>(c)));
  return name;
}

// The proto enum value of a C++ enum value; throws logic_error if none.
template <NamedEnum E>
const pb::EnumValueDescriptor* proto_enum_value(const pb::FieldDescriptor* fd, E value) {
  const pb::EnumDescriptor* e = fd->enum_type();
  for (int i = 0; i < e->value_count(); ++i)
    if (e->value(i)->number() != 0 && proto_enum_key(e->value(i)) == enum_name(value)) return e->value(i);
  throw std::logic_error("options table: " + std::string(fd->full_name()) + " has no value for '" +
                         std::string(enum_name(value)) + "'");
}

[[noreturn]] inline void proto_type_mismatch(const pb::FieldDescriptor* fd) {
  throw std::logic_error("options table: " + std::string(fd->full_name()) + " has type " +
                         fd->cpp_type_name() + ", not the entry's");
}

// Sets field fd of m to v (an option's C++ value).
template <class T>
void set_proto(pb::Message& m, const pb::FieldDescriptor* fd, const T& v) {
  const pb::Reflection* r = m.GetReflection();
  using C = pb::FieldDescriptor::CppType;
  const C type = fd->cpp_type();
  if constexpr (std::is_same_v<T, bool>) {
    if (type != C::CPPTYPE_BOOL) proto_type_mismatch(fd);
    r->SetBool(&m, fd, v);
  } else if constexpr (std::is_same_v<T, uint32_t>) {
    if (type != C::CPPTYPE_UINT32) proto_type_mismatch(fd);
    r->SetUInt32(&m, fd, v);
  } else if constexpr (std::is_same_v<T, uint64_t>) {
    if (type != C::CPPTYPE_UINT64) proto_type_mismatch(fd);
    r->SetUInt64(&m, fd, v);
  } else if constexpr (std::is_same_v<T, float>) {
    if (type != C::CPPTYPE_FLOAT) proto_type_mismatch(fd);
    r->SetFloat(&m, fd, v);
  } else if constexpr (std::is_same_v<T, double>) {
    if (type != C::CPPTYPE_DOUBLE) proto_type_mismatch(fd);
    r->SetDouble(&m, fd, v);
  } else if constexpr (std::is_same_v<T, std::string>) {
    if (type != C::CPPTYPE_STRING) proto_type_mismatch(fd);
    r->SetString(&m, fd, v);
  } else if constexpr (NamedEnum<T>) {
    if (type == C::CPPTYPE_STRING) {
      r->SetString(&m, fd, std::string(enum_name(v)));
    } else if (type == C::CPPTYPE_ENUM) {
      r->SetEnumValue(&m, fd, proto_enum_value(fd, v)->number());
    } else {
      proto_type_mismatch(fd);
    }
  } else {
    static_assert(sizeof(T) == 0, "no proto conversion for this option type");
  }
}

}  // namespace pbgi::options
