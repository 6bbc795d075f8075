// Byte-level pieces of the MCAP format shared by the writer and the reader: opcodes, little-endian
// encoding, and a bounds-checked cursor whose errors carry the file offset.
#pragma once

#include <ddsnav/record/mcap.hpp>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace ddsnav::record::format {

inline constexpr std::uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
inline constexpr std::size_t kRecordPrefix = 9;  // opcode (1) + content length (8)
inline constexpr std::size_t kFooterContent = 8 + 8 + 4;
inline constexpr std::size_t kFooterRecord = kRecordPrefix + kFooterContent;

enum Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

std::string opcodeName(std::uint8_t opcode);
std::uint32_t crc32(const void* data, std::size_t size, std::uint32_t crc = 0);

// Appends little-endian fields to a byte vector.
class Out {
 public:
  explicit Out(std::vector<std::uint8_t>& bytes) : b_(bytes) {}
  void u8(std::uint8_t v) { b_.push_back(v); }
  void u16(std::uint16_t v) { le(v, 2); }
  void u32(std::uint32_t v) { le(v, 4); }
  void u64(std::uint64_t v) { le(v, 8); }
  void raw(const void* data, std::size_t size) {
    const auto* p = static_cast<const std::uint8_t*>(data);
    b_.insert(b_.end(), p, p + size);
  }
  void str(std::string_view s) {
    u32(static_cast<std::uint32_t>(s.size()));
    raw(s.data(), s.size());
  }
  void bytes32(std::string_view s) { str(s); }  // u32-prefixed bytes (Schema data)
  void stringMap(const StringMap& m) {
    const std::size_t at = b_.size();
    u32(0);
    for (const auto& [k, v] : m) {
      str(k);
      str(v);
    }
    patch32(at, static_cast<std::uint32_t>(b_.size() - at - 4));
  }
  void patch32(std::size_t at, std::uint32_t v) {
    for (int i = 0; i < 4; ++i) b_[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
  }
  std::size_t size() const { return b_.size(); }

 private:
  void le(std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) b_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  std::vector<std::uint8_t>& b_;
};

// Reads little-endian fields from a byte range; `base` is the file offset of data[0], so that an error
// can say where in the file the bad field is. Errors throw McapError via the `where` prefix.
class In {
 public:
  In(const std::uint8_t* data, std::size_t size, std::uint64_t base, std::string where)
      : p_(data), n_(size), base_(base), where_(std::move(where)) {}
  std::uint8_t u8() { return static_cast<std::uint8_t>(le(1)); }
  std::uint16_t u16() { return static_cast<std::uint16_t>(le(2)); }
  std::uint32_t u32() { return static_cast<std::uint32_t>(le(4)); }
  std::uint64_t u64() { return le(8); }
  std::string str() {
    const std::uint32_t len = u32();
    need(len, "string");
    std::string s(reinterpret_cast<const char*>(p_ + at_), len);
    at_ += len;
    return s;
  }
  StringMap stringMap() {
    const std::uint32_t len = u32();
    need(len, "map");
    In inner(p_ + at_, len, base_ + at_, where_);
    at_ += len;
    StringMap m;
    while (!inner.done()) {
      std::string k = inner.str();
      m[k] = inner.str();
    }
    return m;
  }
  // A u32-length-prefixed map of fixed-size entries; returns the sub-reader.
  In sub32() {
    const std::uint32_t len = u32();
    need(len, "array");
    In inner(p_ + at_, len, base_ + at_, where_);
    at_ += len;
    return inner;
  }
  const std::uint8_t* take(std::uint64_t len, const char* what) {
    need(len, what);
    const std::uint8_t* p = p_ + at_;
    at_ += len;
    return p;
  }
  std::size_t remaining() const { return n_ - at_; }
  bool done() const { return at_ >= n_; }
  std::uint64_t offset() const { return base_ + at_; }
  [[noreturn]] void fail(const std::string& what) const {
    throw McapError(where_ + ": byte " + std::to_string(offset()) + ": " + what);
  }

 private:
  void need(std::uint64_t len, const char* what) const {
    if (len > n_ - at_)
      fail(std::string("truncated ") + what + ": needs " + std::to_string(len) + " bytes, " +
           std::to_string(n_ - at_) + " left in the record");
  }
  std::uint64_t le(int n) {
    need(static_cast<std::uint64_t>(n), "integer field");
    std::uint64_t v = 0;
    for (int i = 0; i < n; ++i) v |= static_cast<std::uint64_t>(p_[at_ + i]) << (8 * i);
    at_ += n;
    return v;
  }
  const std::uint8_t* p_;
  std::size_t n_;
  std::size_t at_ = 0;
  std::uint64_t base_;
  std::string where_;
};

}  // namespace ddsnav::record::format
