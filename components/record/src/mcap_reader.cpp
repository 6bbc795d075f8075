#include "mcap_format.hpp"

#include <lz4frame.h>
#include <zstd.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <memory>

namespace ddsnav::record {

using namespace format;

namespace {

std::string hex(const std::uint8_t* p, std::size_t n) {
  static const char* digits = "0123456789abcdef";
  std::string s;
  for (std::size_t i = 0; i < n; ++i) {
    if (i) s += ' ';
    s += digits[p[i] >> 4];
    s += digits[p[i] & 15];
  }
  return s;
}

const char* fileKind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  return "not a regular file";
}

// zstd output grows in steps of at most this much beyond what was really decompressed, so memory
// follows the bytes the compressed data produces, not the size the chunk header claims.
constexpr std::size_t kDecompressStep = 16u << 20;

Schema parseSchema(In& in) {
  Schema s;
  s.id = in.u16();
  s.name = in.str();
  s.encoding = in.str();
  s.data = in.str();
  return s;
}

Channel parseChannel(In& in) {
  Channel ch;
  ch.id = in.u16();
  ch.schema_id = in.u16();
  ch.topic = in.str();
  ch.message_encoding = in.str();
  ch.metadata = in.stringMap();
  return ch;
}

Metadata parseMetadata(In& in) {
  Metadata m;
  m.name = in.str();
  m.values = in.stringMap();
  return m;
}

// The fixed fields of a Chunk record; leaves `in` at the compressed records.
ChunkInfo parseChunkHeader(In& in, std::uint64_t offset, std::uint64_t record_length, std::uint32_t& crc,
                           std::uint64_t& records_size) {
  ChunkInfo c;
  c.offset = offset;
  c.record_length = record_length;
  c.message_start_time = in.u64();
  c.message_end_time = in.u64();
  c.uncompressed_size = in.u64();
  crc = in.u32();
  c.compression = in.str();
  records_size = in.u64();
  c.compressed_size = records_size;
  return c;
}

}  // namespace

McapReader::McapReader(const std::string& path, bool force_scan) : path_(path) {
  // Non-blocking open, then a type check: opening a FIFO for reading would otherwise wait for a writer.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw McapError(path + ": cannot open: " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    const int err = errno;
    ::close(fd);
    if (!S_ISREG(st.st_mode) && st.st_mode != 0)
      throw McapError(path + ": " + fileKind(st.st_mode) + ", not a recording: expected a regular .mcap file");
    throw McapError(path + ": cannot stat: " + std::strerror(err));
  }
  file_ = ::fdopen(fd, "rb");
  if (!file_) {
    ::close(fd);
    throw McapError(path + ": cannot open: " + std::strerror(errno));
  }
  try {
    if (fseeko(file_, 0, SEEK_END) != 0) throw McapError(path + ": cannot seek: " + std::strerror(errno));
    file_size_ = static_cast<std::uint64_t>(ftello(file_));
    if (file_size_ < sizeof kMagic)
      fail(0, "not an MCAP file: " + std::to_string(file_size_) + " bytes, shorter than the 8-byte magic");
    const auto magic = readAt(0, sizeof kMagic);
    if (std::memcmp(magic.data(), kMagic, sizeof kMagic) != 0)
      fail(0, "not an MCAP file: expected magic 89 4d 43 41 50 30 0d 0a, found " + hex(magic.data(), magic.size()));
    if (file_size_ < sizeof kMagic + kRecordPrefix) fail(sizeof kMagic, "file ends before the Header record");
    const auto prefix = readAt(sizeof kMagic, kRecordPrefix);
    In p(prefix.data(), prefix.size(), sizeof kMagic, path_);
    const std::uint8_t opcode = p.u8();
    const std::uint64_t length = p.u64();
    if (opcode != kHeader) fail(sizeof kMagic, "expected the Header record (opcode 0x01), found " + opcodeName(opcode));
    if (length > file_size_ - sizeof kMagic - kRecordPrefix) fail(sizeof kMagic, "Header record runs past the end of the file");
    const auto header = readAt(sizeof kMagic + kRecordPrefix, length);
    In h(header.data(), header.size(), sizeof kMagic + kRecordPrefix, path_);
    profile_ = h.str();
    library_ = h.str();

    // A closed file ends with Footer + magic; the footer locates the summary.
    bool closed = false;
    std::uint64_t summary_start = 0, summary_offset_start = 0;
    std::uint32_t summary_crc = 0;
    const std::uint64_t footer_at = file_size_ >= kFooterRecord + 2 * sizeof kMagic ? file_size_ - sizeof kMagic - kFooterRecord : 0;
    if (footer_at > sizeof kMagic) {
      const auto tail = readAt(footer_at, kFooterRecord + sizeof kMagic);
      In f(tail.data(), tail.size(), footer_at, path_);
      const std::uint8_t op = f.u8();
      const std::uint64_t len = f.u64();
      summary_start = f.u64();
      summary_offset_start = f.u64();
      summary_crc = f.u32();
      closed = op == kFooter && len == kFooterContent &&
               std::memcmp(tail.data() + kFooterRecord, kMagic, sizeof kMagic) == 0;
    }
    if (closed && !force_scan && summary_start != 0 && summary_start < footer_at &&
        summary_offset_start >= summary_start && summary_offset_start <= footer_at) {
      // The CRC covers the summary through the footer's summary_offset_start field.
      const auto summary = readAt(summary_start, footer_at + kRecordPrefix + 16 - summary_start);
      if (summary_crc == 0 || crc32(summary.data(), summary.size()) == summary_crc) {
        try {
          readSummary(summary_start, summary_offset_start);
          has_summary_ = true;
        } catch (const McapError&) {
          // A damaged summary: the data section still holds everything; read it record by record.
          schemas_.clear();
          channels_.clear();
          chunks_.clear();
          metadata_.clear();
          loose_messages_.clear();
          summary_ = {};
        }
      }
    }
    if (!has_summary_) {
      scan();
      if (!closed && !truncated_) {
        truncated_ = true;
        truncated_at_ = file_size_;
        truncation_reason_ = "no footer: the recorder did not close the file";
      }
    }
  } catch (...) {
    std::fclose(file_);
    file_ = nullptr;
    throw;
  }
}

McapReader::~McapReader() {
  if (file_) std::fclose(file_);
}

void McapReader::fail(std::uint64_t offset, const std::string& what) const {
  throw McapError(path_ + ": byte " + std::to_string(offset) + ": " + what);
}

std::vector<std::uint8_t> McapReader::readAt(std::uint64_t offset, std::uint64_t size) const {
  if (offset > file_size_ || size > file_size_ - offset)
    fail(offset, std::to_string(size) + " bytes needed, the file ends at byte " + std::to_string(file_size_));
  std::vector<std::uint8_t> out(size);
  if (fseeko(file_, static_cast<off_t>(offset), SEEK_SET) != 0 ||
      (size > 0 && std::fread(out.data(), 1, size, file_) != size))
    fail(offset, std::string("read failed: ") + std::strerror(errno));
  return out;
}

void McapReader::readSummary(std::uint64_t summary_start, std::uint64_t summary_offset_start) {
  const auto bytes = readAt(summary_start, summary_offset_start - summary_start);
  In in(bytes.data(), bytes.size(), summary_start, path_);
  bool statistics = false;
  while (!in.done()) {
    const std::uint64_t at = in.offset();
    const std::uint8_t opcode = in.u8();
    const std::uint64_t length = in.u64();
    const std::uint8_t* content = in.take(length, "summary record");
    In r(content, length, at + kRecordPrefix, path_);
    switch (opcode) {
      case kSchema: {
        Schema s = parseSchema(r);
        schemas_[s.id] = std::move(s);
        break;
      }
      case kChannel: {
        Channel ch = parseChannel(r);
        channels_[ch.id] = std::move(ch);
        break;
      }
      case kStatistics: {
        summary_.message_count = r.u64();
        r.u16();
        r.u32();
        r.u32();
        r.u32();
        r.u32();
        summary_.message_start_time = r.u64();
        summary_.message_end_time = r.u64();
        In counts = r.sub32();
        while (!counts.done()) {
          const std::uint16_t channel = counts.u16();
          summary_.channel_message_counts[channel] = counts.u64();
        }
        statistics = true;
        break;
      }
      case kChunkIndex: {
        ChunkInfo c;
        c.message_start_time = r.u64();
        c.message_end_time = r.u64();
        c.offset = r.u64();
        c.record_length = r.u64();
        In offsets = r.sub32();
        while (!offsets.done()) {
          const std::uint16_t channel = offsets.u16();
          c.message_index_offsets[channel] = offsets.u64();
        }
        c.message_index_length = r.u64();
        c.compression = r.str();
        c.compressed_size = r.u64();
        c.uncompressed_size = r.u64();
        if (c.offset > file_size_ || c.record_length > file_size_ - c.offset)
          r.fail("ChunkIndex points outside the file (chunk at byte " + std::to_string(c.offset) + ")");
        chunks_.push_back(std::move(c));
        break;
      }
      case kMetadataIndex: {
        const std::uint64_t offset = r.u64();
        const std::uint64_t record_length = r.u64();
        if (record_length < kRecordPrefix) r.fail("MetadataIndex with a record length below 9");
        const auto rec = readAt(offset, record_length);
        if (rec[0] != kMetadata) fail(offset, "MetadataIndex points at a " + opcodeName(rec[0]) + " record");
        In m(rec.data() + kRecordPrefix, rec.size() - kRecordPrefix, offset + kRecordPrefix, path_);
        metadata_.push_back(parseMetadata(m));
        break;
      }
      default:
        break;  // SummaryOffset, attachment indexes, future records: not needed
    }
  }
  if (!statistics) fail(summary_start, "summary without a Statistics record");
  std::sort(chunks_.begin(), chunks_.end(), [](const ChunkInfo& a, const ChunkInfo& b) { return a.offset < b.offset; });
  // The summary indexes chunks only. Messages outside chunks are valid MCAP (other writers make files with
  // no chunks at all); when the chunks' message indexes do not account for every counted message, walk
  // the data section's record headers to find the loose ones.
  if (indexedChunkMessages() < summary_.message_count) findLooseMessages(summary_start);
}

std::uint64_t McapReader::indexedChunkMessages() const {
  // A MessageIndex record is opcode + length (9) + channel (2) + entries byte length (4) + 16 per message,
  // so the ChunkIndex's index length and index count give the message count without reading anything.
  std::uint64_t count = 0;
  for (const ChunkInfo& c : chunks_) {
    const std::uint64_t overhead = (kRecordPrefix + 2 + 4) * c.message_index_offsets.size();
    if (c.message_index_offsets.empty() || c.message_index_length < overhead) return 0;  // unindexed: unknown
    count += (c.message_index_length - overhead) / 16;
  }
  return count;
}

void McapReader::findLooseMessages(std::uint64_t summary_start) {
  // Record headers only: chunks are skipped, not decoded. Stops at DataEnd (or the summary).
  std::uint64_t offset = sizeof kMagic;
  while (offset + kRecordPrefix <= summary_start) {
    const auto prefix = readAt(offset, kRecordPrefix);
    In p(prefix.data(), prefix.size(), offset, path_);
    const std::uint8_t opcode = p.u8();
    const std::uint64_t length = p.u64();
    if (length > summary_start - offset - kRecordPrefix)
      fail(offset, opcodeName(opcode) + " record runs into the summary section");
    if (opcode == kDataEnd) break;
    if (opcode == kMessage) loose_messages_.push_back(offset);
    offset += kRecordPrefix + length;
  }
}

void McapReader::scan() {
  // Record by record from after the Header. Anything after the first incomplete or undecodable record is
  // ignored and reported: that is where a killed recorder stopped.
  std::uint64_t offset = sizeof kMagic;
  {
    const auto prefix = readAt(offset, kRecordPrefix);
    In p(prefix.data(), prefix.size(), offset, path_);
    p.u8();
    offset += kRecordPrefix + p.u64();
  }
  auto stop = [&](std::uint64_t at, const std::string& why) {
    truncated_ = true;
    truncated_at_ = at;
    truncation_reason_ = why;
  };
  bool first_message = true;
  auto count = [&](std::uint16_t channel, std::uint64_t log_time) {
    ++summary_.message_count;
    ++summary_.channel_message_counts[channel];
    if (first_message) summary_.message_start_time = summary_.message_end_time = log_time;
    first_message = false;
    summary_.message_start_time = std::min(summary_.message_start_time, log_time);
    summary_.message_end_time = std::max(summary_.message_end_time, log_time);
  };
  while (offset < file_size_) {
    if (file_size_ - offset < kRecordPrefix) return stop(offset, "incomplete record header");
    const auto prefix = readAt(offset, kRecordPrefix);
    In p(prefix.data(), prefix.size(), offset, path_);
    const std::uint8_t opcode = p.u8();
    const std::uint64_t length = p.u64();
    if (length > file_size_ - offset - kRecordPrefix)
      return stop(offset, opcodeName(opcode) + " record of " + std::to_string(length) + " bytes, only " +
                              std::to_string(file_size_ - offset - kRecordPrefix) + " left in the file");
    if (opcode == kDataEnd || opcode == kFooter) return;  // the summary that follows repeats what we have
    const std::uint64_t content_at = offset + kRecordPrefix;
    try {
      switch (opcode) {
        case kSchema: {
          const auto content = readAt(content_at, length);
          In r(content.data(), content.size(), content_at, path_);
          Schema s = parseSchema(r);
          schemas_[s.id] = std::move(s);
          break;
        }
        case kChannel: {
          const auto content = readAt(content_at, length);
          In r(content.data(), content.size(), content_at, path_);
          Channel ch = parseChannel(r);
          channels_[ch.id] = std::move(ch);
          break;
        }
        case kMessage: {
          const auto content = readAt(content_at, std::min<std::uint64_t>(length, 22));
          In r(content.data(), content.size(), content_at, path_);
          const std::uint16_t channel = r.u16();
          r.u32();
          const std::uint64_t log_time = r.u64();
          count(channel, log_time);
          loose_messages_.push_back(offset);
          break;
        }
        case kChunk: {
          // The record's length is sound (checked above), so a chunk that does not decode is skipped,
          // not the end of the file: the chunks after it are as good as the ones before.
          try {
            const auto content = readAt(content_at, length);
            In r(content.data(), content.size(), content_at, path_);
            std::uint32_t crc = 0;
            std::uint64_t records_size = 0;
            ChunkInfo c = parseChunkHeader(r, offset, kRecordPrefix + length, crc, records_size);
            // Decoding validates it (size, CRC) and counts its messages; counted only once it all parsed.
            const auto records = chunkRecords(c);
            In m(records.data(), records.size(), 0, path_ + ": chunk at byte " + std::to_string(offset));
            std::vector<std::pair<std::uint16_t, std::uint64_t>> messages;
            std::vector<Schema> schemas;
            std::vector<Channel> channels;
            while (!m.done()) {
              const std::uint8_t op = m.u8();
              const std::uint64_t len = m.u64();
              const std::uint8_t* body = m.take(len, "record in chunk");
              In b(body, len, 0, path_ + ": chunk at byte " + std::to_string(offset));
              if (op == kMessage) {
                const std::uint16_t channel = b.u16();
                b.u32();
                messages.emplace_back(channel, b.u64());
              } else if (op == kSchema) {
                schemas.push_back(parseSchema(b));
              } else if (op == kChannel) {
                channels.push_back(parseChannel(b));
              }
            }
            for (const auto& [channel, log_time] : messages) count(channel, log_time);
            for (Schema& s : schemas) schemas_[s.id] = std::move(s);
            for (Channel& ch : channels) channels_[ch.id] = std::move(ch);
            chunks_.push_back(std::move(c));
          } catch (const McapError& e) {
            damaged_.push_back({offset, e.what()});
          }
          break;
        }
        case kMessageIndex: {
          // Fill in the chunk's index table as the writer would have put it in the summary.
          if (!chunks_.empty()) {
            const auto content = readAt(content_at, 2);
            chunks_.back().message_index_offsets[static_cast<std::uint16_t>(content[0] | content[1] << 8)] = offset;
            chunks_.back().message_index_length += kRecordPrefix + length;
          }
          break;
        }
        case kMetadata: {
          const auto content = readAt(content_at, length);
          In r(content.data(), content.size(), content_at, path_);
          metadata_.push_back(parseMetadata(r));
          break;
        }
        default:
          break;  // attachments and records this reader does not use
      }
    } catch (const McapError& e) {
      return stop(offset, std::string("damaged ") + opcodeName(opcode) + " record: " + e.what());
    }
    offset += kRecordPrefix + length;
  }
  stop(file_size_, "the file ends without a DataEnd record");
}

std::vector<std::uint8_t> McapReader::chunkRecords(const ChunkInfo& chunk) const {
  const auto record = readAt(chunk.offset, chunk.record_length);
  if (record.empty() || record[0] != kChunk) fail(chunk.offset, "expected a Chunk record");
  In r(record.data() + kRecordPrefix, record.size() - kRecordPrefix, chunk.offset + kRecordPrefix, path_);
  std::uint32_t crc = 0;
  std::uint64_t size = 0;
  const ChunkInfo c = parseChunkHeader(r, chunk.offset, chunk.record_length, crc, size);
  const std::uint8_t* data = r.take(size, "chunk records");
  // The claimed size comes from the file: checked against a named cap before any allocation, and for
  // zstd the output grows only as far as the compressed bytes really expand.
  if (c.uncompressed_size > kMaxChunkUncompressedBytes)
    fail(chunk.offset, "chunk claims " + std::to_string(c.uncompressed_size) + " uncompressed bytes (limit " +
                           std::to_string(kMaxChunkUncompressedBytes) + ", kMaxChunkUncompressedBytes)");
  std::vector<std::uint8_t> out;
  if (c.compression.empty()) {
    if (size != c.uncompressed_size)
      fail(chunk.offset, "uncompressed chunk of " + std::to_string(size) + " bytes claims " +
                             std::to_string(c.uncompressed_size));
    out.assign(data, data + size);
  } else if (c.compression == "zstd") {
    std::unique_ptr<ZSTD_DCtx, decltype(&ZSTD_freeDCtx)> dctx(ZSTD_createDCtx(), &ZSTD_freeDCtx);
    ZSTD_inBuffer in{data, size, 0};
    std::size_t produced = 0;
    for (;;) {
      // Room for the next step, never past the claimed size (+1 byte to notice output beyond it).
      const std::size_t want = static_cast<std::size_t>(std::min<std::uint64_t>(c.uncompressed_size + 1, produced + kDecompressStep));
      out.resize(want);
      ZSTD_outBuffer o{out.data(), out.size(), produced};
      const std::size_t rc = ZSTD_decompressStream(dctx.get(), &o, &in);
      if (ZSTD_isError(rc)) fail(chunk.offset, std::string("zstd chunk does not decompress: ") + ZSTD_getErrorName(rc));
      produced = o.pos;
      if (produced > c.uncompressed_size)
        fail(chunk.offset, "zstd chunk decompresses to more than the " + std::to_string(c.uncompressed_size) +
                               " bytes it claims");
      if (rc == 0 && in.pos == in.size) break;                    // frame complete, input used up
      if (in.pos == in.size && o.pos < o.size) break;             // input used up mid-frame: short
    }
    out.resize(produced);
    if (produced != c.uncompressed_size)
      fail(chunk.offset, "zstd chunk decompressed to " + std::to_string(produced) + " bytes, expected " +
                             std::to_string(c.uncompressed_size));
  } else if (c.compression == "lz4") {
    // An LZ4 frame, decompressed in the same bounded steps as zstd.
    LZ4F_dctx* raw_dctx = nullptr;
    if (LZ4F_isError(LZ4F_createDecompressionContext(&raw_dctx, LZ4F_VERSION))) fail(chunk.offset, "lz4: no decompression context");
    std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> dctx(raw_dctx, &LZ4F_freeDecompressionContext);
    std::size_t consumed = 0, produced = 0, rc = 1;
    while (rc != 0) {
      const std::size_t want = static_cast<std::size_t>(std::min<std::uint64_t>(c.uncompressed_size + 1, produced + kDecompressStep));
      out.resize(std::max<std::size_t>(want, produced + 1));
      std::size_t out_n = out.size() - produced, in_n = size - consumed;
      rc = LZ4F_decompress(dctx.get(), out.data() + produced, &out_n, data + consumed, &in_n, nullptr);
      if (LZ4F_isError(rc)) fail(chunk.offset, std::string("lz4 chunk does not decompress: ") + LZ4F_getErrorName(rc));
      produced += out_n;
      consumed += in_n;
      if (produced > c.uncompressed_size)
        fail(chunk.offset, "lz4 chunk decompresses to more than the " + std::to_string(c.uncompressed_size) + " bytes it claims");
      if (rc != 0 && out_n == 0 && in_n == 0) break;  // no progress: the input ends mid-frame
    }
    out.resize(produced);
    if (rc != 0 || consumed != size || produced != c.uncompressed_size)
      fail(chunk.offset, "lz4 chunk decompressed to " + std::to_string(produced) + " bytes, expected " +
                             std::to_string(c.uncompressed_size) + (rc != 0 ? " (the frame is incomplete)" : ""));
  } else {
    fail(chunk.offset, "chunk compression '" + c.compression + "' is not supported (only zstd, lz4 or none)");
  }
  if (crc != 0 && crc32(out.data(), out.size()) != crc) fail(chunk.offset, "chunk CRC mismatch: the chunk is damaged");
  return out;
}

void McapReader::forEachMessage(const std::function<bool(const MessageView&)>& callback,
                                const DamagedChunkHandler& on_damaged) const {
  auto deliver = [&](In& b, std::uint64_t where) {
    MessageView m;
    const std::uint16_t channel = b.u16();
    const auto it = channels_.find(channel);
    if (it == channels_.end()) fail(where, "message on channel " + std::to_string(channel) + ", which no Channel record defines");
    m.channel = &it->second;
    m.sequence = b.u32();
    m.log_time = b.u64();
    m.publish_time = b.u64();
    // The size first: the order in which a call's arguments are evaluated is unspecified (clang: left to
    // right, so remaining() after take() was 0 and every message read back empty).
    const std::size_t size = b.remaining();
    m.data = std::span<const std::uint8_t>(b.take(size, "message data"), size);
    return callback(m);
  };
  // Damaged chunks found while scanning were left out of chunks_: report them in file order too.
  std::size_t damaged = 0;
  auto reportDamagedBefore = [&](std::uint64_t limit) {
    for (; damaged < damaged_.size() && damaged_[damaged].offset < limit; ++damaged) {
      const std::uint64_t at = damaged_[damaged].offset;
      const bool listed = std::any_of(chunks_.begin(), chunks_.end(), [&](const ChunkInfo& c) { return c.offset == at; });
      if (listed) continue;  // reported when its turn comes below
      if (!on_damaged) throw McapError(damaged_[damaged].reason);
      on_damaged(damaged_[damaged]);
    }
  };
  // Loose messages and chunks, in file order.
  std::size_t loose = 0;
  for (std::size_t ci = 0; ci <= chunks_.size(); ++ci) {
    const std::uint64_t limit = ci < chunks_.size() ? chunks_[ci].offset : file_size_;
    for (; loose < loose_messages_.size() && loose_messages_[loose] < limit; ++loose) {
      const std::uint64_t at = loose_messages_[loose];
      const auto prefix = readAt(at, kRecordPrefix);
      In p(prefix.data(), prefix.size(), at, path_);
      p.u8();
      const auto content = readAt(at + kRecordPrefix, p.u64());
      In b(content.data(), content.size(), at + kRecordPrefix, path_);
      if (!deliver(b, at)) return;
    }
    reportDamagedBefore(limit);
    if (ci == chunks_.size()) break;
    std::vector<std::uint8_t> records;
    try {
      records = chunkRecords(chunks_[ci]);
    } catch (const McapError& e) {
      if (!on_damaged) throw;
      on_damaged({chunks_[ci].offset, e.what()});
      continue;
    }
    In m(records.data(), records.size(), 0, path_ + ": chunk at byte " + std::to_string(chunks_[ci].offset));
    while (!m.done()) {
      const std::uint8_t op = m.u8();
      const std::uint64_t len = m.u64();
      const std::uint8_t* body = m.take(len, "record in chunk");
      if (op != kMessage) continue;
      In b(body, len, 0, path_ + ": chunk at byte " + std::to_string(chunks_[ci].offset));
      if (!deliver(b, chunks_[ci].offset)) return;
    }
  }
  reportDamagedBefore(~0ull);
}

const std::vector<DamagedChunk>& McapReader::verifyChunks() {
  for (const ChunkInfo& c : chunks_) {
    try {
      const auto records = chunkRecords(c);
      In m(records.data(), records.size(), 0, path_ + ": chunk at byte " + std::to_string(c.offset));
      while (!m.done()) {
        m.u8();
        m.take(m.u64(), "record in chunk");
      }
    } catch (const McapError& e) {
      const bool known = std::any_of(damaged_.begin(), damaged_.end(), [&](const DamagedChunk& d) { return d.offset == c.offset; });
      if (!known) damaged_.push_back({c.offset, e.what()});
    }
  }
  std::sort(damaged_.begin(), damaged_.end(), [](const DamagedChunk& a, const DamagedChunk& b) { return a.offset < b.offset; });
  return damaged_;
}

}  // namespace ddsnav::record
