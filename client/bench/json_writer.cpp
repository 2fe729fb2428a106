#include "client/bench/json_writer.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <cmath>

namespace pbgi::bench {

std::string json_quote(std::string_view s) {
  std::string out = "\"";
  for (const char c : s) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20)
          out += fmt::format("\\u{:04x}", static_cast<unsigned>(c));
        else
          out += c;
    }
  }
  return out + "\"";
}

void JsonWriter::newline() {
  out_ += '\n';
  out_.append(2 * stack_.size(), ' ');
}

void JsonWriter::before_value() {
  if (after_key_) {
    after_key_ = false;
    return;
  }
  if (stack_.empty()) {
    if (!out_.empty()) throw InvalidArgument("json: more than one top-level value");
    return;
  }
  if (!stack_.back().array) throw InvalidArgument("json: value inside an object without a key");
  if (!stack_.back().empty) out_ += ',';
  stack_.back().empty = false;
  newline();
}

void JsonWriter::key(std::string_view k) {
  if (stack_.empty() || stack_.back().array || after_key_)
    throw InvalidArgument("json: key '" + std::string(k) + "' outside an object");
  if (!stack_.back().empty) out_ += ',';
  stack_.back().empty = false;
  newline();
  out_ += json_quote(k);
  out_ += ": ";
  after_key_ = true;
}

void JsonWriter::begin_object() {
  before_value();
  out_ += '{';
  stack_.push_back({false, true});
}

void JsonWriter::begin_array() {
  before_value();
  out_ += '[';
  stack_.push_back({true, true});
}

void JsonWriter::end_object() {
  if (stack_.empty() || stack_.back().array || after_key_)
    throw InvalidArgument("json: end_object without a matching begin_object");
  const bool empty = stack_.back().empty;
  stack_.pop_back();
  if (!empty) newline();
  out_ += '}';
}

void JsonWriter::end_array() {
  if (stack_.empty() || !stack_.back().array)
    throw InvalidArgument("json: end_array without a matching begin_array");
  const bool empty = stack_.back().empty;
  stack_.pop_back();
  if (!empty) newline();
  out_ += ']';
}

void JsonWriter::value(std::string_view s) {
  before_value();
  out_ += json_quote(s);
}

void JsonWriter::value(double v) {
  before_value();
  // Shortest form that reads back to the same double.
  out_ += std::isfinite(v) ? fmt::format("{}", v) : "null";
}

void JsonWriter::value(uint64_t v) {
  before_value();
  out_ += std::to_string(v);
}

void JsonWriter::value(bool v) {
  before_value();
  out_ += v ? "true" : "false";
}

void JsonWriter::null() {
  before_value();
  out_ += "null";
}

const std::string& JsonWriter::str() const {
  if (!stack_.empty() || after_key_) throw InvalidArgument("json: document not closed");
  return out_;
}

}  // namespace pbgi::bench
