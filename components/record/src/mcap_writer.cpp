#include "mcap_format.hpp"

#include <zlib.h>
#include <zstd.h>

#include <cerrno>
#include <cstring>
#include <functional>
#include <iostream>
#include <tuple>

namespace ddsnav::record {

std::string_view compressionName(Compression c) { return c == Compression::Zstd ? "zstd" : ""; }

namespace format {

std::uint32_t crc32(const void* data, std::size_t size, std::uint32_t crc) {
  // zlib's CRC-32 is the one MCAP specifies (IEEE 802.3 polynomial, reflected, final xor).
  const auto* p = static_cast<const Bytef*>(data);
  while (size > 0) {
    const uInt n = size > (1u << 30) ? (1u << 30) : static_cast<uInt>(size);
    crc = static_cast<std::uint32_t>(::crc32(crc, p, n));
    p += n;
    size -= n;
  }
  return crc;
}

std::string opcodeName(std::uint8_t opcode) {
  switch (opcode) {
    case kHeader: return "Header";
    case kFooter: return "Footer";
    case kSchema: return "Schema";
    case kChannel: return "Channel";
    case kMessage: return "Message";
    case kChunk: return "Chunk";
    case kMessageIndex: return "MessageIndex";
    case kChunkIndex: return "ChunkIndex";
    case kAttachment: return "Attachment";
    case kAttachmentIndex: return "AttachmentIndex";
    case kStatistics: return "Statistics";
    case kMetadata: return "Metadata";
    case kMetadataIndex: return "MetadataIndex";
    case kSummaryOffset: return "SummaryOffset";
    case kDataEnd: return "DataEnd";
    default: return "unknown opcode " + std::to_string(opcode);
  }
}

}  // namespace format

using namespace format;

McapWriter::McapWriter(const std::string& path, McapWriterOptions options) : path_(path), options_(std::move(options)) {
  if (options_.chunk_size == 0) throw McapError(path_ + ": chunk size must be positive");
  file_ = std::fopen(path.c_str(), "wb");
  if (!file_) throw McapError(path_ + ": cannot create file: " + std::strerror(errno));
  if (options_.compression == Compression::Zstd) {
    zstd_ = ZSTD_createCCtx();
    ZSTD_CCtx_setParameter(static_cast<ZSTD_CCtx*>(zstd_), ZSTD_c_compressionLevel, options_.zstd_level);
  }
  writeBytes(kMagic, sizeof kMagic);
  std::vector<std::uint8_t> header;
  Out out(header);
  out.str(options_.profile);
  out.str(options_.library);
  writeRecord(kHeader, header);
  flushFile();
}

McapWriter::~McapWriter() {
  try {
    close();
  } catch (const std::exception& e) {
    std::cerr << e.what() << '\n';
  }
  if (zstd_) ZSTD_freeCCtx(static_cast<ZSTD_CCtx*>(zstd_));
}

void McapWriter::writeBytes(const void* data, std::size_t size) {
  if (!file_) throw McapError(path_ + ": write after close");
  if (size > 0 && std::fwrite(data, 1, size, file_) != size)
    throw McapError(path_ + ": write failed at byte " + std::to_string(position_) + ": " + std::strerror(errno));
  position_ += size;
}

void McapWriter::flushFile() {
  // Buffered bytes reach the OS here; a full disk shows up now, not at fwrite.
  if (std::fflush(file_) != 0)
    throw McapError(path_ + ": write failed at byte " + std::to_string(position_) + ": " + std::strerror(errno));
}

void McapWriter::writeRecord(std::uint8_t opcode, const std::vector<std::uint8_t>& content) {
  std::uint8_t prefix[kRecordPrefix];
  prefix[0] = opcode;
  const std::uint64_t len = content.size();
  for (int i = 0; i < 8; ++i) prefix[1 + i] = static_cast<std::uint8_t>(len >> (8 * i));
  writeBytes(prefix, sizeof prefix);
  writeBytes(content.data(), content.size());
}

namespace {
std::vector<std::uint8_t> schemaContent(const Schema& s) {
  std::vector<std::uint8_t> c;
  Out out(c);
  out.u16(s.id);
  out.str(s.name);
  out.str(s.encoding);
  out.bytes32(s.data);
  return c;
}
std::vector<std::uint8_t> channelContent(const Channel& ch) {
  std::vector<std::uint8_t> c;
  Out out(c);
  out.u16(ch.id);
  out.u16(ch.schema_id);
  out.str(ch.topic);
  out.str(ch.message_encoding);
  out.stringMap(ch.metadata);
  return c;
}
}  // namespace

std::uint16_t McapWriter::addSchema(const std::string& name, const std::string& encoding, const std::string& data) {
  // Schema id 0 means "no schema" in MCAP, so ids start at 1.
  if (schemas_.size() >= 0xFFFE) throw McapError(path_ + ": too many schemas");
  Schema s{static_cast<std::uint16_t>(schemas_.size() + 1), name, encoding, data};
  // Outside chunks, flushed at once: a truncated file still knows every schema and channel.
  writeRecord(kSchema, schemaContent(s));
  flushFile();
  schemas_.push_back(std::move(s));
  return schemas_.back().id;
}

std::uint16_t McapWriter::addChannel(std::uint16_t schema_id, const std::string& topic,
                                     const std::string& message_encoding, const StringMap& metadata) {
  if (schema_id > schemas_.size()) throw McapError(path_ + ": channel '" + topic + "': unknown schema id " + std::to_string(schema_id));
  if (channels_.size() >= 0xFFFF) throw McapError(path_ + ": too many channels");
  Channel ch{static_cast<std::uint16_t>(channels_.size()), schema_id, topic, message_encoding, metadata};
  writeRecord(kChannel, channelContent(ch));
  flushFile();
  channels_.push_back(std::move(ch));
  sequences_.push_back(0);
  return channels_.back().id;
}

void McapWriter::write(std::uint16_t channel_id, std::uint64_t log_time, std::uint64_t publish_time,
                       std::span<const std::uint8_t> data) {
  if (channel_id >= channels_.size()) throw McapError(path_ + ": message on unknown channel " + std::to_string(channel_id));
  if (chunk_records_.empty()) {
    chunk_start_ = log_time;
    chunk_end_ = log_time;
    chunk_opened_ = std::chrono::steady_clock::now();
  }
  chunk_start_ = std::min(chunk_start_, log_time);
  chunk_end_ = std::max(chunk_end_, log_time);
  chunk_index_[channel_id].emplace_back(log_time, chunk_records_.size());
  Out out(chunk_records_);
  out.u8(kMessage);
  out.u64(2 + 4 + 8 + 8 + data.size());
  out.u16(channel_id);
  out.u32(++sequences_[channel_id]);
  out.u64(log_time);
  out.u64(publish_time);
  out.raw(data.data(), data.size());
  if (message_count_ == 0) start_time_ = end_time_ = log_time;
  start_time_ = std::min(start_time_, log_time);
  end_time_ = std::max(end_time_, log_time);
  ++message_count_;
  ++channel_counts_[channel_id];
  if (chunk_records_.size() >= options_.chunk_size) closeChunk();
}

void McapWriter::closeChunk() {
  if (chunk_records_.empty()) return;
  ChunkInfo info;
  info.offset = position_;
  info.message_start_time = chunk_start_;
  info.message_end_time = chunk_end_;
  info.uncompressed_size = chunk_records_.size();
  info.compression = std::string(compressionName(options_.compression));

  std::vector<std::uint8_t> compressed;
  const std::vector<std::uint8_t>* payload = &chunk_records_;
  if (options_.compression == Compression::Zstd) {
    compressed.resize(ZSTD_compressBound(chunk_records_.size()));
    const std::size_t n = ZSTD_compress2(static_cast<ZSTD_CCtx*>(zstd_), compressed.data(), compressed.size(),
                                         chunk_records_.data(), chunk_records_.size());
    if (ZSTD_isError(n)) throw McapError(path_ + ": zstd compression failed: " + ZSTD_getErrorName(n));
    compressed.resize(n);
    payload = &compressed;
  }
  info.compressed_size = payload->size();

  std::vector<std::uint8_t> content;
  content.reserve(payload->size() + 64);
  Out out(content);
  out.u64(chunk_start_);
  out.u64(chunk_end_);
  out.u64(chunk_records_.size());
  out.u32(crc32(chunk_records_.data(), chunk_records_.size()));
  out.str(info.compression);
  out.u64(payload->size());
  out.raw(payload->data(), payload->size());
  writeRecord(kChunk, content);
  info.record_length = position_ - info.offset;

  for (const auto& [channel, entries] : chunk_index_) {
    info.message_index_offsets[channel] = position_;
    std::vector<std::uint8_t> index;
    Out ix(index);
    ix.u16(channel);
    ix.u32(static_cast<std::uint32_t>(entries.size() * 16));
    for (const auto& [time, offset] : entries) {
      ix.u64(time);
      ix.u64(offset);
    }
    writeRecord(kMessageIndex, index);
  }
  info.message_index_length = position_ - (info.offset + info.record_length);
  chunks_.push_back(std::move(info));
  chunk_records_.clear();
  chunk_index_.clear();
  // The chunk is complete in the OS's hands: a killed recorder keeps it.
  flushFile();
}

void McapWriter::flushAged() {
  if (!chunk_records_.empty() && std::chrono::steady_clock::now() - chunk_opened_ >= options_.chunk_age) closeChunk();
}

void McapWriter::flush() {
  closeChunk();
  if (file_) flushFile();
}

void McapWriter::addMetadata(const std::string& name, const StringMap& values) {
  closeChunk();  // Metadata lives in the data section between chunks.
  std::vector<std::uint8_t> content;
  Out out(content);
  out.str(name);
  out.stringMap(values);
  const std::uint64_t at = position_;
  writeRecord(kMetadata, content);
  metadata_offsets_.emplace_back(at, position_ - at);
  metadata_names_.push_back(name);
  flushFile();
}

namespace {
void appendRecord(std::vector<std::uint8_t>& out, std::uint8_t opcode, const std::vector<std::uint8_t>& content) {
  Out o(out);
  o.u8(opcode);
  o.u64(content.size());
  o.raw(content.data(), content.size());
}
}  // namespace

void McapWriter::close() {
  if (!file_) return;
  closeChunk();
  std::vector<std::uint8_t> c;
  Out(c).u32(0);  // data section CRC: 0 = not computed (every chunk carries its own CRC)
  writeRecord(kDataEnd, c);

  // Summary: one group per record type, each located by a SummaryOffset record. Built in memory so its
  // CRC can go into the footer.
  const std::uint64_t summary_start = position_;
  std::vector<std::uint8_t> tail;
  std::vector<std::tuple<std::uint8_t, std::uint64_t, std::uint64_t>> groups;
  auto group = [&](std::uint8_t opcode, const std::function<void()>& body) {
    const std::size_t start = tail.size();
    body();
    if (tail.size() > start) groups.emplace_back(opcode, summary_start + start, tail.size() - start);
  };
  group(kSchema, [&] { for (const auto& s : schemas_) appendRecord(tail, kSchema, schemaContent(s)); });
  group(kChannel, [&] { for (const auto& ch : channels_) appendRecord(tail, kChannel, channelContent(ch)); });
  group(kStatistics, [&] {
    std::vector<std::uint8_t> s;
    Out out(s);
    out.u64(message_count_);
    out.u16(static_cast<std::uint16_t>(schemas_.size()));
    out.u32(static_cast<std::uint32_t>(channels_.size()));
    out.u32(0);  // attachments
    out.u32(static_cast<std::uint32_t>(metadata_offsets_.size()));
    out.u32(static_cast<std::uint32_t>(chunks_.size()));
    out.u64(start_time_);
    out.u64(end_time_);
    out.u32(static_cast<std::uint32_t>(channel_counts_.size() * 10));
    for (const auto& [channel, count] : channel_counts_) {
      out.u16(channel);
      out.u64(count);
    }
    appendRecord(tail, kStatistics, s);
  });
  group(kChunkIndex, [&] {
    for (const auto& ch : chunks_) {
      std::vector<std::uint8_t> s;
      Out out(s);
      out.u64(ch.message_start_time);
      out.u64(ch.message_end_time);
      out.u64(ch.offset);
      out.u64(ch.record_length);
      out.u32(static_cast<std::uint32_t>(ch.message_index_offsets.size() * 10));
      for (const auto& [channel, offset] : ch.message_index_offsets) {
        out.u16(channel);
        out.u64(offset);
      }
      out.u64(ch.message_index_length);
      out.str(ch.compression);
      out.u64(ch.compressed_size);
      out.u64(ch.uncompressed_size);
      appendRecord(tail, kChunkIndex, s);
    }
  });
  group(kMetadataIndex, [&] {
    for (std::size_t i = 0; i < metadata_offsets_.size(); ++i) {
      std::vector<std::uint8_t> s;
      Out out(s);
      out.u64(metadata_offsets_[i].first);
      out.u64(metadata_offsets_[i].second);
      out.str(metadata_names_[i]);
      appendRecord(tail, kMetadataIndex, s);
    }
  });
  const std::uint64_t summary_offset_start = summary_start + tail.size();
  for (const auto& [opcode, start, length] : groups) {
    std::vector<std::uint8_t> s;
    Out out(s);
    out.u8(opcode);
    out.u64(start);
    out.u64(length);
    appendRecord(tail, kSummaryOffset, s);
  }
  // Footer; its CRC covers the summary through the footer's summary_offset_start field.
  Out out(tail);
  out.u8(kFooter);
  out.u64(kFooterContent);
  out.u64(summary_start);
  out.u64(summary_offset_start);
  out.u32(crc32(tail.data(), tail.size()));
  out.raw(kMagic, sizeof kMagic);
  writeBytes(tail.data(), tail.size());
  const int rc = std::fclose(file_);
  file_ = nullptr;
  if (rc != 0) throw McapError(path_ + ": closing failed: " + std::strerror(errno));
}

}  // namespace ddsnav::record
