// Builds one TypeSupport per generated class from the class's Fast CDR code, and pairs it with the idlc
// descriptor of the same IDL struct (the Cyclone side of the bus creates its topics from it).
#include <ddsnav/msg/messages.hpp>

#include <ddsnav/msg/make_type_support.hpp>
#include <ddsnav/msg/registry.hpp>

#include <dlfcn.h>

#include <cstdlib>
#include <mutex>
#include <stdexcept>
#include <string>

// The idlc descriptors, declared without Cyclone's headers: only their addresses are used here (the bus's
// Cyclone backend casts them back to dds_topic_descriptor_t).
#define DDSNAV_MESSAGE(T) extern "C" const dds_topic_descriptor ddsnav_msg_##T##_desc;
#include <ddsnav/msg/type_list.inc>
#undef DDSNAV_MESSAGE

namespace ddsnav::msg {

#define DDSNAV_MESSAGE(T)                                                                     \
  template <>                                                                                 \
  const TypeSupport& type_support<T>() {                                                      \
    static const TypeSupport ts = makeTypeSupport<T>("ddsnav::msg::" #T, &ddsnav_msg_##T##_desc); \
    return ts;                                                                                \
  }
#include <ddsnav/msg/type_list.inc>
#undef DDSNAV_MESSAGE

namespace {

struct Registry {
  std::mutex mutex;
  std::vector<const TypeSupport*> types;
  std::vector<std::string_view> schemas;  // per type; empty for the stock ones
  std::vector<std::string> owners;  // library that registered types[i] ("ddsnav_msgs" for the stock ones)
  std::string conflict;             // first duplicate name seen, reported by the next lookup
};

Registry& registry() {
  static Registry* r = [] {
    auto* init = new Registry;  // never destroyed: libraries may register from their own static init
#define DDSNAV_MESSAGE(T) \
  init->types.push_back(&type_support<T>()); init->schemas.emplace_back(); init->owners.emplace_back("ddsnav_msgs");
#include <ddsnav/msg/type_list.inc>
#undef DDSNAV_MESSAGE
    return init;
  }();
  return *r;
}

// DDSNAV_MESSAGE_LIBRARIES, once per process (a failed load is retried, and reported, on every lookup).
void loadLibrariesFromEnvironment() {
  static std::once_flag loaded;
  std::call_once(loaded, [] {
    const char* value = std::getenv(kMessageLibrariesVariable);
    std::string list = value ? value : "";
    std::size_t from = 0;
    while (from <= list.size()) {
      const std::size_t colon = list.find(':', from);
      const std::string path = list.substr(from, colon == std::string::npos ? std::string::npos : colon - from);
      if (!path.empty() && !::dlopen(path.c_str(), RTLD_NOW | RTLD_GLOBAL)) {
        const char* why = ::dlerror();
        throw std::runtime_error(std::string(kMessageLibrariesVariable) + ": cannot load message library '" + path +
                                 "': " + (why ? why : "unknown error"));
      }
      if (colon == std::string::npos) break;
      from = colon + 1;
    }
  });
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  if (!r.conflict.empty()) throw std::runtime_error(r.conflict);
}

}  // namespace

bool registerMessageLibrary(std::string_view library, std::initializer_list<RegisteredType> types) {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  for (const RegisteredType& entry : types) {
    const TypeSupport* type = entry.type;
    bool known = false;
    for (std::size_t i = 0; i < r.types.size(); ++i) {
      if (r.types[i]->name != type->name) continue;
      known = true;
      if (r.types[i] != type && r.conflict.empty())
        r.conflict = "message type " + std::string(type->name) + " is defined by both " + r.owners[i] + " and " +
                     std::string(library) + "; rename one of them (module and struct name must be unique)";
    }
    if (known) continue;
    r.types.push_back(type);
    r.schemas.push_back(entry.omgidl_schema);
    r.owners.emplace_back(library);
  }
  return true;
}

std::string_view registeredSchema(std::string_view type_name) {
  loadLibrariesFromEnvironment();
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  for (std::size_t i = 0; i < r.types.size(); ++i)
    if (r.types[i]->name == type_name) return r.schemas[i];
  return {};
}

const std::vector<const TypeSupport*>& all_type_supports() {
  loadLibrariesFromEnvironment();
  return registry().types;
}

const TypeSupport* find_type_support(std::string_view type_name) {
  for (const TypeSupport* ts : all_type_supports())
    if (ts->name == type_name) return ts;
  return nullptr;
}

}  // namespace ddsnav::msg
