#include <ddsnav/record/schemas.hpp>

#include <ddsnav/msg/registry.hpp>

#include <map>
#include <regex>
#include <sstream>

namespace ddsnav::record {

// Generated from idl/*.idl: { {"common", R"(...)"}, ... }.
struct IdlFile {
  const char* name;
  const char* text;
};
extern const IdlFile kIdlFiles[];
extern const std::size_t kIdlFileCount;

namespace {

std::string withoutIncludes(const std::string& text) {
  std::istringstream in(text);
  std::string line, out;
  while (std::getline(in, line))
    if (!line.starts_with("#include")) out += line + '\n';
  return out;
}

const IdlFile* fileNamed(const std::string& name) {
  for (std::size_t i = 0; i < kIdlFileCount; ++i)
    if (name == kIdlFiles[i].name) return &kIdlFiles[i];
  return nullptr;
}

// Files `file` includes, depth first, each once.
void collect(const IdlFile& file, std::vector<const IdlFile*>& order) {
  for (const IdlFile* f : order)
    if (f == &file) return;
  static const std::regex include_line(R"re(#include\s+"([A-Za-z0-9_]+)\.idl")re");
  const std::string text = file.text;
  for (std::sregex_iterator it(text.begin(), text.end(), include_line), end; it != end; ++it)
    if (const IdlFile* dep = fileNamed((*it)[1].str())) collect(*dep, order);
  order.push_back(&file);
}

}  // namespace

std::optional<std::string> idlSchemaFor(std::string_view type_name) {
  // Every ddsnav type lives in module ddsnav::msg; the struct name is the last component.
  constexpr std::string_view prefix = "ddsnav::msg::";
  if (!type_name.starts_with(prefix)) {
    // A ddsnav_add_messages() type carries its own schema (linked, or loaded from DDSNAV_MESSAGE_LIBRARIES).
    const std::string_view schema = msg::registeredSchema(type_name);
    if (schema.empty()) return std::nullopt;
    return std::string(schema);
  }
  const std::string name(type_name.substr(prefix.size()));
  const std::regex declares("struct\\s+" + name + "\\s*\\{");
  for (std::size_t i = 0; i < kIdlFileCount; ++i) {
    if (!std::regex_search(kIdlFiles[i].text, declares)) continue;
    std::vector<const IdlFile*> order;
    collect(kIdlFiles[i], order);
    std::string text;
    for (const IdlFile* f : order) text += "// " + std::string(f->name) + ".idl\n" + withoutIncludes(f->text);
    return text;
  }
  return std::nullopt;
}

}  // namespace ddsnav::record
