#pragma once
// Text that came off the wire (a status detail, a frame id, a topic or type name from discovery) is
// untrusted bytes: escape it once, here, before it reaches a log line or a terminal, so a payload
// cannot inject escape sequences, fake log lines (newlines) or hide behind a NUL.
//
//   spdlog::warn("cloud in frame '{}'", bus::printable(cloud.header().frame_id()));

#include <cstddef>
#include <string>
#include <string_view>

namespace ddsnav::bus {

// Bytes shown of one wire string; the rest is summarised as "...(N bytes)".
inline constexpr std::size_t kMaxPrintableBytes = 256;

// Printable ASCII is kept; backslash, \n, \r, \t are written as C escapes; every other byte (control
// characters, DEL, anything >= 0x80) as \xNN. Longer than `max_bytes`: cut, with the full size noted.
inline std::string printable(std::string_view text, std::size_t max_bytes = kMaxPrintableBytes) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  const std::size_t shown = text.size() < max_bytes ? text.size() : max_bytes;
  out.reserve(shown + 16);
  for (std::size_t i = 0; i < shown; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    switch (c) {
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (c >= 0x20 && c < 0x7f) {
          out += static_cast<char>(c);
        } else {
          out += "\\x";
          out += kHex[c >> 4];
          out += kHex[c & 0xf];
        }
    }
  }
  if (shown < text.size()) out += "...(" + std::to_string(text.size()) + " bytes)";
  return out;
}

}  // namespace ddsnav::bus
