#include "storage/format/byte_stream.h"

#include "common/errors.h"

namespace pbgi::storage {

void ByteWriter::put_string(std::string_view s) {
  put<uint32_t>(static_cast<uint32_t>(s.size()));
  put_bytes({reinterpret_cast<const uint8_t*>(s.data()), s.size()});
}

void ByteReader::require(size_t n, const char* field) const {
  if (n > remaining()) {
    throw CorruptionError(what_ + ": truncated at offset " + std::to_string(file_offset()) +
                          ": field '" + field + "' needs " + std::to_string(n) + " bytes, " +
                          std::to_string(remaining()) + " left");
  }
}

std::span<const uint8_t> ByteReader::get_bytes(size_t n, const char* field) {
  require(n, field);
  auto s = bytes_.subspan(pos_, n);
  pos_ += n;
  return s;
}

std::string ByteReader::get_string(const char* field, uint32_t max_length) {
  const uint64_t at = file_offset();
  const uint32_t n = get<uint32_t>(field);
  if (n > max_length) {
    throw CorruptionError(what_ + ": at offset " + std::to_string(at) + ": field '" + field +
                          "' has length " + std::to_string(n) + ", more than the limit " +
                          std::to_string(max_length));
  }
  auto b = get_bytes(n, field);
  return {reinterpret_cast<const char*>(b.data()), b.size()};
}

void ByteReader::expect_end() const {
  if (remaining() != 0) {
    throw CorruptionError(what_ + ": " + std::to_string(remaining()) +
                          " unexpected trailing bytes at offset " + std::to_string(file_offset()));
  }
}

}  // namespace pbgi::storage
