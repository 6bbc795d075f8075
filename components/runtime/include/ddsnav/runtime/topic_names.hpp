// What a topic name (or a namespace) may contain, checked where names enter: --namespace, --remap and a
// launch file's namespace:/remap:. Header-only and dependency-free, so the launcher checks the same way.
#pragma once

#include <cstdio>
#include <string>
#include <string_view>

namespace ddsnav::runtime {

// Letters, digits, '_' and '/' (not first, not last, not doubled): what both vendors accept in a topic
// name and what ROS users expect. Empty when fine, else the complaint naming the first bad character.
inline std::string topicNameError(std::string_view name) {
  if (name.empty()) return "is empty";
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '/';
    if (ok) continue;
    std::string shown;
    if (c >= 0x20 && c <= 0x7e) {
      shown = std::string("'") + c + "'";
    } else {
      char hex[16];
      std::snprintf(hex, sizeof hex, "byte 0x%02x", static_cast<unsigned char>(c));
      shown = hex;
    }
    return "contains " + shown + ", which a DDS topic name cannot carry (letters, digits, '_' and '/' only)";
  }
  if (name.front() == '/' || name.back() == '/') return "must not begin or end with '/'";
  if (name.find("//") != std::string_view::npos) return "must not contain '//'";
  return "";
}

}  // namespace ddsnav::runtime
