// Type-erased access to the generated message classes, so that the bus (and record/replay) can move any
// message as XCDR1 bytes without templates in vendor code. One TypeSupport per IDL struct, built in
// idl/type_support.cpp from the fastddsgen class's own Fast CDR code.
//
// Component code normally includes <ddsnav/msg/messages.hpp> (every message class) and never needs this
// header directly.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <type_traits>
#include <vector>

namespace ddsnav::msg {

struct TypeSupport {
  std::string_view name;  // registered name on both vendors, e.g. "ddsnav::msg::PointCloud"
  bool keyed = false;     // has @key fields
  std::size_t key_max_size = 0;  // upper bound of the key's CDR size (> 16 -> key hash is an MD5)

  void* (*create)() = nullptr;
  void (*destroy)(void* sample) = nullptr;
  // Bytes of the serialized form: 4-byte encapsulation header + XCDR1 body.
  std::size_t (*serialized_size)(const void* sample) = nullptr;
  // Writes header + body into buffer; returns the bytes written, 0 when capacity is too small.
  std::size_t (*serialize)(const void* sample, void* buffer, std::size_t capacity) = nullptr;
  // Reads header + body (either endianness). False when the bytes do not hold a complete sample.
  bool (*deserialize)(const void* buffer, std::size_t size, void* sample) = nullptr;
  // Big-endian CDR of the key fields, the input of the RTPS key hash. Empty for unkeyed types.
  void (*serialize_key)(const void* sample, std::vector<unsigned char>& out) = nullptr;

  const void* cyclone_descriptor = nullptr;  // the idlc dds_topic_descriptor_t of the same type
};

// True for every generated class (specialised in the generated <ddsnav/msg/messages.hpp>).
template <class T>
struct IsMessage : std::false_type {};

// The TypeSupport of a generated class; specialised for each one in messages.hpp.
template <class T>
const TypeSupport& type_support();

// The wire bytes (encapsulation + XCDR1) of one message, e.g. to record, replay or feed a decoder in tests.
template <class T>
std::vector<std::uint8_t> serializeToBytes(const T& sample) {
  const TypeSupport& type = type_support<T>();
  std::vector<std::uint8_t> bytes(type.serialized_size(&sample));
  bytes.resize(type.serialize(&sample, bytes.data(), bytes.size()));
  return bytes;
}

// By registered name, e.g. from a recorded file or a discovered topic. nullptr when unknown.
const TypeSupport* find_type_support(std::string_view type_name);

// Every known type, in IDL order.
const std::vector<const TypeSupport*>& all_type_supports();

}  // namespace ddsnav::msg
