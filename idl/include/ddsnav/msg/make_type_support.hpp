// Builds the TypeSupport of one fastddsgen class from its own Fast CDR code. Used by idl/type_support.cpp
// for the stock types and by the registration code ddsnav_add_messages() generates for a user's types;
// component code never includes it.
#pragma once

#include <ddsnav/msg/type_support.hpp>

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastcdr/exceptions/Exception.h>

#include <new>
#include <stdexcept>
#include <string_view>
#include <vector>

struct dds_topic_descriptor;  // idlc's descriptor; only its address is kept here

namespace ddsnav::msg {
namespace detail {

template <class T>
std::size_t serializedSize(const void* sample) {
  return T::getCdrSerializedSize(*static_cast<const T*>(sample)) + 4;  // + encapsulation
}

template <class T>
std::size_t serialize(const void* sample, void* buffer, std::size_t capacity) {
  eprosima::fastcdr::FastBuffer fb(static_cast<char*>(buffer), capacity);
  eprosima::fastcdr::Cdr cdr(fb, eprosima::fastcdr::Cdr::DEFAULT_ENDIAN, eprosima::fastcdr::Cdr::DDS_CDR);
  try {
    cdr.serialize_encapsulation();
    static_cast<const T*>(sample)->serialize(cdr);
  } catch (const eprosima::fastcdr::exception::Exception&) {
    return 0;
  }
  return cdr.getSerializedDataLength();
}

template <class T>
bool deserialize(const void* buffer, std::size_t size, void* sample) {
  // Fast CDR only reads through the buffer; the cast is for its non-const constructor.
  eprosima::fastcdr::FastBuffer fb(static_cast<char*>(const_cast<void*>(buffer)), size);
  eprosima::fastcdr::Cdr cdr(fb, eprosima::fastcdr::Cdr::DEFAULT_ENDIAN, eprosima::fastcdr::Cdr::DDS_CDR);
  try {
    cdr.read_encapsulation();
    static_cast<T*>(sample)->deserialize(cdr);
  } catch (const eprosima::fastcdr::exception::Exception&) {
    return false;
  } catch (const std::bad_alloc&) {  // a corrupt sequence length
    return false;
  } catch (const std::length_error&) {
    return false;
  }
  return true;
}

template <class T>
void serializeKey(const void* sample, std::vector<unsigned char>& out) {
  out.clear();
  if (!T::isKeyDefined()) return;
  eprosima::fastcdr::FastBuffer fb;  // grows as needed: string keys have no fixed bound
  eprosima::fastcdr::Cdr cdr(fb, eprosima::fastcdr::Cdr::BIG_ENDIANNESS);
  static_cast<const T*>(sample)->serializeKey(cdr);
  out.assign(fb.getBuffer(), fb.getBuffer() + cdr.getSerializedDataLength());
}

}  // namespace detail

// `name` is the registered (IDL-qualified) name, e.g. "ddsnav::msg::Path".
template <class T>
TypeSupport makeTypeSupport(std::string_view name, const dds_topic_descriptor* descriptor) {
  TypeSupport ts;
  ts.name = name;
  ts.keyed = T::isKeyDefined();
  ts.key_max_size = T::getKeyMaxCdrSerializedSize();
  ts.create = [] { return static_cast<void*>(new T()); };
  ts.destroy = [](void* s) { delete static_cast<T*>(s); };
  ts.serialized_size = &detail::serializedSize<T>;
  ts.serialize = &detail::serialize<T>;
  ts.deserialize = &detail::deserialize<T>;
  ts.serialize_key = &detail::serializeKey<T>;
  ts.cyclone_descriptor = descriptor;
  return ts;
}

}  // namespace ddsnav::msg
