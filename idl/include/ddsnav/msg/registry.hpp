// The type registry behind msg::find_type_support() / msg::all_type_supports(): the stock types, then those
// of every ddsnav_add_messages() library this process has loaded, by linking it or through
// DDSNAV_MESSAGE_LIBRARIES (colon-separated paths of such libraries, dlopen'ed on the first lookup), so the
// stock `ddsnav record`, `play` and `echo` handle a user's types.
//
// Lookups throw std::runtime_error naming the variable and the file when an entry cannot be loaded, and
// naming both libraries when two of them register the same type name.
#pragma once

#include <ddsnav/msg/type_support.hpp>

#include <initializer_list>
#include <string_view>

namespace ddsnav::msg {

inline constexpr const char* kMessageLibrariesVariable = "DDSNAV_MESSAGE_LIBRARIES";

struct RegisteredType {
  const TypeSupport* type;
  std::string_view omgidl_schema;  // self-contained OMG IDL text, stored as the type's schema by the recorder
};

// Adds a library's types (called by the code ddsnav_add_messages() generates, when the library loads).
// Returns true; a name already registered by another library is reported by the next lookup.
bool registerMessageLibrary(std::string_view library, std::initializer_list<RegisteredType> types);

// The schema a ddsnav_add_messages() library registered for `type_name`; empty for the stock types
// (components/record embeds idl/*.idl for them) and for unknown names.
std::string_view registeredSchema(std::string_view type_name);

}  // namespace ddsnav::msg
