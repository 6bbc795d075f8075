// Builds one TypeSupport per generated class from the class's Fast CDR code, and pairs it with the idlc
// descriptor of the same IDL struct (the Cyclone side of the bus creates its topics from it).
#include <ddsnav/msg/messages.hpp>

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastcdr/exceptions/Exception.h>

#include <new>
#include <string>

// The idlc descriptors, declared without Cyclone's headers: only their addresses are used here (the bus's
// Cyclone backend casts them back to dds_topic_descriptor_t).
struct dds_topic_descriptor;
#define DDSNAV_MESSAGE(T) extern "C" const dds_topic_descriptor ddsnav_msg_##T##_desc;
#include <ddsnav/msg/type_list.inc>
#undef DDSNAV_MESSAGE

namespace ddsnav::msg {
namespace {

using eprosima::fastcdr::Cdr;
using eprosima::fastcdr::FastBuffer;

template <class T>
std::size_t serializedSize(const void* sample) {
  return T::getCdrSerializedSize(*static_cast<const T*>(sample)) + 4;  // + encapsulation
}

template <class T>
std::size_t serialize(const void* sample, void* buffer, std::size_t capacity) {
  FastBuffer fb(static_cast<char*>(buffer), capacity);
  Cdr cdr(fb, Cdr::DEFAULT_ENDIAN, Cdr::DDS_CDR);
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
  FastBuffer fb(static_cast<char*>(const_cast<void*>(buffer)), size);
  Cdr cdr(fb, Cdr::DEFAULT_ENDIAN, Cdr::DDS_CDR);
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
  FastBuffer fb;  // grows as needed: string keys have no fixed bound
  Cdr cdr(fb, Cdr::BIG_ENDIANNESS);
  static_cast<const T*>(sample)->serializeKey(cdr);
  out.assign(fb.getBuffer(), fb.getBuffer() + cdr.getSerializedDataLength());
}

template <class T>
TypeSupport make(std::string_view name, const dds_topic_descriptor* descriptor) {
  TypeSupport ts;
  ts.name = name;
  ts.keyed = T::isKeyDefined();
  ts.key_max_size = T::getKeyMaxCdrSerializedSize();
  ts.create = [] { return static_cast<void*>(new T()); };
  ts.destroy = [](void* s) { delete static_cast<T*>(s); };
  ts.serialized_size = &serializedSize<T>;
  ts.serialize = &serialize<T>;
  ts.deserialize = &deserialize<T>;
  ts.serialize_key = &serializeKey<T>;
  ts.cyclone_descriptor = descriptor;
  return ts;
}

}  // namespace

#define DDSNAV_MESSAGE(T)                                                                     \
  template <>                                                                                 \
  const TypeSupport& type_support<T>() {                                                      \
    static const TypeSupport ts = make<T>("ddsnav::msg::" #T, &ddsnav_msg_##T##_desc);        \
    return ts;                                                                                \
  }
#include <ddsnav/msg/type_list.inc>
#undef DDSNAV_MESSAGE

const std::vector<const TypeSupport*>& all_type_supports() {
  static const std::vector<const TypeSupport*> all = {
#define DDSNAV_MESSAGE(T) &type_support<T>(),
#include <ddsnav/msg/type_list.inc>
#undef DDSNAV_MESSAGE
  };
  return all;
}

const TypeSupport* find_type_support(std::string_view type_name) {
  for (const TypeSupport* ts : all_type_supports())
    if (ts->name == type_name) return ts;
  return nullptr;
}

}  // namespace ddsnav::msg
