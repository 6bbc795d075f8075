#include "mcap_format.hpp"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#include <isa-l/crc.h>
#include <lz4frame.h>
#include <zstd.h>

#include <algorithm>
#include <cerrno>
#include <condition_variable>
#include <cstring>
#include <functional>
#include <iostream>
#include <mutex>
#include <thread>
#include <tuple>

namespace ddsnav::record {

std::string_view compressionName(Compression c) {
  switch (c) {
    case Compression::Zstd: return "zstd";
    case Compression::Lz4: return "lz4";
    case Compression::None: break;
  }
  return "";
}

void lowerThreadPriority(int increment) {
  // Linux keeps a nice value per thread: PRIO_PROCESS with the thread id changes only this thread.
  const auto tid = static_cast<id_t>(::syscall(SYS_gettid));
  errno = 0;
  const int current = ::getpriority(PRIO_PROCESS, tid);
  if (errno == 0) ::setpriority(PRIO_PROCESS, tid, std::min(19, current + increment));
}

namespace format {

std::uint32_t crc32(const void* data, std::size_t size, std::uint32_t crc) {
  // The CRC-32 MCAP specifies (IEEE 802.3 polynomial, reflected, final xor: zlib's crc32), computed by
  // ISA-L's folding implementation; crc32_gzip_refl chains like zlib's (pass the previous result).
  const auto* p = static_cast<const unsigned char*>(data);
  while (size > 0) {
    const std::uint64_t n = std::min<std::uint64_t>(size, 1ull << 30);
    crc = ::crc32_gzip_refl(crc, p, n);
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

// One thread's compression context: zstd's or LZ4's, made for the writer's options.
struct McapWriter::Compressor {
  Compression compression;
  int lz4_level = 0;
  ZSTD_CCtx* zstd = nullptr;
  LZ4F_cctx* lz4 = nullptr;

  Compressor(const McapWriterOptions& options) : compression(options.compression), lz4_level(options.lz4_level) {
    if (compression == Compression::Zstd) {
      zstd = ZSTD_createCCtx();
      ZSTD_CCtx_setParameter(zstd, ZSTD_c_compressionLevel, options.zstd_level);
    } else if (compression == Compression::Lz4) {
      LZ4F_createCompressionContext(&lz4, LZ4F_VERSION);
    }
  }
  ~Compressor() {
    if (zstd) ZSTD_freeCCtx(zstd);
    if (lz4) LZ4F_freeCompressionContext(lz4);
  }
  Compressor(const Compressor&) = delete;
  Compressor& operator=(const Compressor&) = delete;
};

// A closed chunk on its way to the file: records and index from the writer, CRC and compressed bytes from
// a worker (or the calling thread). Its bytes are `records` with each attached payload inserted at its
// offset; nothing assembles them into one buffer.
struct McapWriter::PendingChunk {
  std::vector<std::uint8_t> records;
  std::vector<Attached> attached;
  std::uint64_t size = 0;  // records + attached payloads: the chunk's uncompressed size
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> index;
  std::uint64_t start = 0, end = 0;
  std::vector<std::uint8_t> compressed;  // empty for Compression::None
  std::uint32_t crc = 0;
  std::string error;
  bool done = false;  // guarded by the pool's mutex

  // The chunk's bytes in order, as contiguous pieces.
  template <class F>
  void forEachPiece(F&& piece) const {
    std::size_t from = 0;
    for (const Attached& a : attached) {
      if (a.at > from) piece(records.data() + from, a.at - from);
      piece(a.bytes.data(), a.bytes.size());
      from = a.at;
    }
    if (records.size() > from) piece(records.data() + from, records.size() - from);
  }

  void encode(Compressor& compressor) {
    crc = 0;
    forEachPiece([&](const std::uint8_t* p, std::size_t n) { crc = crc32(p, n, crc); });
    if (compressor.compression == Compression::Zstd) encodeZstd(compressor.zstd);
    else if (compressor.compression == Compression::Lz4) encodeLz4(compressor.lz4, compressor.lz4_level);
  }

  void encodeZstd(ZSTD_CCtx* cctx) {
    compressed.resize(ZSTD_compressBound(size));
    if (attached.empty()) {
      const std::size_t n = ZSTD_compress2(cctx, compressed.data(), compressed.size(), records.data(), records.size());
      if (ZSTD_isError(n)) return fail(n);
      compressed.resize(n);
      return;
    }
    // One frame streamed from the pieces; with an output buffer of compressBound() no call stalls.
    ZSTD_CCtx_reset(cctx, ZSTD_reset_session_only);
    ZSTD_CCtx_setPledgedSrcSize(cctx, size);
    ZSTD_outBuffer out{compressed.data(), compressed.size(), 0};
    std::size_t rc = 0;
    forEachPiece([&](const std::uint8_t* p, std::size_t n) {
      ZSTD_inBuffer in{p, n, 0};
      while (!ZSTD_isError(rc) && in.pos < in.size) rc = ZSTD_compressStream2(cctx, &out, &in, ZSTD_e_continue);
    });
    ZSTD_inBuffer none{nullptr, 0, 0};
    do {
      if (ZSTD_isError(rc)) return fail(rc);
      rc = ZSTD_compressStream2(cctx, &out, &none, ZSTD_e_end);
    } while (rc != 0);
    compressed.resize(out.pos);
  }

  void encodeLz4(LZ4F_cctx* cctx, int level) {
    // One LZ4 frame (what MCAP's "lz4" means) with the content size in its header, streamed from the
    // pieces. Blocks are linked (matches across the 64 KB blocks); no frame checksum: the chunk has its CRC.
    LZ4F_preferences_t prefs = LZ4F_INIT_PREFERENCES;
    prefs.compressionLevel = level;
    prefs.frameInfo.contentSize = size;
    prefs.frameInfo.blockMode = LZ4F_blockLinked;
    std::size_t bound = LZ4F_HEADER_SIZE_MAX + LZ4F_compressBound(0, &prefs);
    forEachPiece([&](const std::uint8_t*, std::size_t n) { bound += LZ4F_compressBound(n, &prefs); });
    compressed.resize(bound);
    std::size_t at = LZ4F_compressBegin(cctx, compressed.data(), compressed.size(), &prefs);
    if (LZ4F_isError(at)) return failLz4(at);
    std::size_t rc = 0;
    forEachPiece([&](const std::uint8_t* p, std::size_t n) {
      if (LZ4F_isError(rc)) return;
      rc = LZ4F_compressUpdate(cctx, compressed.data() + at, compressed.size() - at, p, n, nullptr);
      if (!LZ4F_isError(rc)) at += rc;
    });
    if (LZ4F_isError(rc)) return failLz4(rc);
    rc = LZ4F_compressEnd(cctx, compressed.data() + at, compressed.size() - at, nullptr);
    if (LZ4F_isError(rc)) return failLz4(rc);
    compressed.resize(at + rc);
  }

  void failLz4(std::size_t lz4_result) {
    error = std::string("lz4 compression failed: ") + LZ4F_getErrorName(lz4_result);
    compressed.clear();
  }

  void fail(std::size_t zstd_result) {
    error = std::string("zstd compression failed: ") + ZSTD_getErrorName(zstd_result);
    compressed.clear();
  }
};

// Worker threads that encode closed chunks, each with its own zstd context.
class McapWriter::Pool {
 public:
  Pool(unsigned threads, const McapWriterOptions& options) {
    for (unsigned i = 0; i < threads; ++i)
      workers_.emplace_back([this, options] {
        if (options.worker_nice != 0) lowerThreadPriority(options.worker_nice);
        Compressor compressor(options);
        run(compressor);
      });
  }
  ~Pool() {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    work_.notify_all();
    for (auto& t : workers_) t.join();
  }
  void submit(std::shared_ptr<PendingChunk> chunk) {
    {
      std::lock_guard lock(mutex_);
      queue_.push_back(std::move(chunk));
    }
    work_.notify_one();
  }
  bool done(const PendingChunk& chunk) {
    std::lock_guard lock(mutex_);
    return chunk.done;
  }
  void wait(const PendingChunk& chunk) {
    std::unique_lock lock(mutex_);
    finished_.wait(lock, [&] { return chunk.done; });
  }

 private:
  void run(Compressor& compressor) {
    for (;;) {
      std::shared_ptr<PendingChunk> chunk;
      {
        std::unique_lock lock(mutex_);
        work_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
        if (queue_.empty()) return;
        chunk = std::move(queue_.front());
        queue_.pop_front();
      }
      chunk->encode(compressor);
      {
        std::lock_guard lock(mutex_);
        chunk->done = true;
      }
      finished_.notify_all();
    }
  }
  std::mutex mutex_;
  std::condition_variable work_, finished_;
  std::deque<std::shared_ptr<PendingChunk>> queue_;
  bool stopping_ = false;
  std::vector<std::thread> workers_;
};

McapWriter::McapWriter(const std::string& path, McapWriterOptions options) : path_(path), options_(std::move(options)) {
  if (options_.chunk_size == 0) throw McapError(path_ + ": chunk size must be positive");
  if (options_.max_pending_chunks == 0) throw McapError(path_ + ": max_pending_chunks must be positive");
  file_ = std::fopen(path.c_str(), "wb");
  if (!file_) throw McapError(path_ + ": cannot create file: " + std::strerror(errno));
  if (options_.compression_threads > 0)
    pool_ = std::make_unique<Pool>(options_.compression_threads, options_);
  else
    compressor_ = std::make_unique<Compressor>(options_);
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
  pool_.reset();  // joins the workers
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

void McapWriter::appendMessageHeader(std::uint16_t channel_id, std::uint64_t log_time, std::uint64_t publish_time,
                                     std::size_t size) {
  if (channel_id >= channels_.size()) throw McapError(path_ + ": message on unknown channel " + std::to_string(channel_id));
  if (chunk_records_.empty()) {
    chunk_start_ = log_time;
    chunk_end_ = log_time;
    chunk_opened_ = std::chrono::steady_clock::now();
  }
  chunk_start_ = std::min(chunk_start_, log_time);
  chunk_end_ = std::max(chunk_end_, log_time);
  chunk_index_[channel_id].emplace_back(log_time, openChunkBytes());
  Out out(chunk_records_);
  out.u8(kMessage);
  out.u64(2 + 4 + 8 + 8 + size);
  out.u16(channel_id);
  out.u32(++sequences_[channel_id]);
  out.u64(log_time);
  out.u64(publish_time);
}

void McapWriter::afterMessage(std::uint16_t channel_id, std::uint64_t log_time) {
  if (message_count_ == 0) start_time_ = end_time_ = log_time;
  start_time_ = std::min(start_time_, log_time);
  end_time_ = std::max(end_time_, log_time);
  ++message_count_;
  ++channel_counts_[channel_id];
  if (openChunkBytes() >= options_.chunk_size) closeChunk();
}

void McapWriter::write(std::uint16_t channel_id, std::uint64_t log_time, std::uint64_t publish_time,
                       std::span<const std::uint8_t> data) {
  appendMessageHeader(channel_id, log_time, publish_time, data.size());
  Out(chunk_records_).raw(data.data(), data.size());
  afterMessage(channel_id, log_time);
}

void McapWriter::write(std::uint16_t channel_id, std::uint64_t log_time, std::uint64_t publish_time,
                       std::vector<std::uint8_t>&& data) {
  if (data.size() < kAttachBytes) {
    // Copying a small payload costs less than keeping track of it.
    write(channel_id, log_time, publish_time, std::span<const std::uint8_t>(data));
    data.clear();
    released_.push_back(std::move(data));
    return;
  }
  appendMessageHeader(channel_id, log_time, publish_time, data.size());
  chunk_attached_bytes_ += data.size();
  chunk_attached_.push_back(Attached{chunk_records_.size(), std::move(data)});
  afterMessage(channel_id, log_time);
}

std::vector<std::vector<std::uint8_t>> McapWriter::takeReleasedBuffers() {
  std::vector<std::vector<std::uint8_t>> out;
  out.swap(released_);
  return out;
}

void McapWriter::closeChunk() {
  if (chunk_records_.empty()) return;
  auto chunk = std::make_shared<PendingChunk>();
  chunk->size = openChunkBytes();
  chunk->records.swap(chunk_records_);
  chunk->attached.swap(chunk_attached_);
  chunk_attached_bytes_ = 0;
  chunk->index.swap(chunk_index_);
  chunk->start = chunk_start_;
  chunk->end = chunk_end_;
  // The next chunk fills a buffer that already has its capacity: no page faults per chunk.
  if (!spare_buffers_.empty()) {
    chunk_records_.swap(spare_buffers_.back());
    spare_buffers_.pop_back();
  }
  chunk_records_.clear();
  if (!pool_) {
    chunk->encode(*compressor_);
    chunk->done = true;
    pending_.push_back(std::move(chunk));
    writePending(true);
    return;
  }
  pool_->submit(chunk);
  pending_.push_back(std::move(chunk));
  writePending(false);
}

std::map<std::uint16_t, std::uint64_t> McapWriter::unwrittenMessages() const {
  std::map<std::uint16_t, std::uint64_t> out;
  for (const auto& [channel, entries] : chunk_index_) out[channel] += entries.size();
  for (const auto& chunk : pending_)
    for (const auto& [channel, entries] : chunk->index) out[channel] += entries.size();
  return out;
}

std::uint64_t McapWriter::bytesBuffered() const {
  std::uint64_t n = openChunkBytes();
  for (const auto& chunk : pending_) n += chunk->size;
  return n;
}

void McapWriter::writeFinishedChunks() {
  if (file_) writePending(false);
}

void McapWriter::writePending(bool wait_all) {
  // In file order: the oldest pending chunk first, waiting for it only when the backlog is full.
  // A chunk leaves pending_ only once it is in the file: after a failure, unwrittenMessages() still
  // counts it.
  while (!pending_.empty()) {
    PendingChunk& front = *pending_.front();
    if (pool_ && !pool_->done(front)) {
      if (!wait_all && pending_.size() <= options_.max_pending_chunks) return;
      pool_->wait(front);
    }
    writeChunk(front);
    pending_.pop_front();
  }
}

void McapWriter::writeChunk(PendingChunk& chunk) {
  if (!chunk.error.empty()) throw McapError(path_ + ": " + chunk.error);
  ChunkInfo info;
  info.offset = position_;
  info.message_start_time = chunk.start;
  info.message_end_time = chunk.end;
  info.uncompressed_size = chunk.size;
  info.compression = std::string(compressionName(options_.compression));
  const bool compressed = options_.compression != Compression::None;
  const std::uint64_t payload_size = compressed ? chunk.compressed.size() : chunk.size;
  info.compressed_size = payload_size;

  // Record prefix and the chunk's fixed fields, then the payload straight from its buffers (no copy).
  std::vector<std::uint8_t> head;
  Out out(head);
  out.u8(kChunk);
  out.u64(8 + 8 + 8 + 4 + 4 + info.compression.size() + 8 + payload_size);
  out.u64(chunk.start);
  out.u64(chunk.end);
  out.u64(chunk.size);
  out.u32(chunk.crc);
  out.str(info.compression);
  out.u64(payload_size);
  writeBytes(head.data(), head.size());
  if (compressed) writeBytes(chunk.compressed.data(), chunk.compressed.size());
  else chunk.forEachPiece([&](const std::uint8_t* p, std::size_t n) { writeBytes(p, n); });
  info.record_length = position_ - info.offset;

  for (const auto& [channel, entries] : chunk.index) {
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
  if (spare_buffers_.size() < options_.max_pending_chunks + 1) spare_buffers_.push_back(std::move(chunk.records));
  for (Attached& a : chunk.attached) {
    a.bytes.clear();
    released_.push_back(std::move(a.bytes));
  }
  chunk.attached.clear();
  // The chunk is complete in the OS's hands: a killed recorder keeps it.
  flushFile();
}

void McapWriter::flushAged() {
  if (!chunk_records_.empty() && std::chrono::steady_clock::now() - chunk_opened_ >= options_.chunk_age) closeChunk();
  writeFinishedChunks();
}

void McapWriter::flush() {
  closeChunk();
  writePending(true);
  if (file_) flushFile();
}

void McapWriter::addMetadata(const std::string& name, const StringMap& values) {
  closeChunk();  // Metadata lives in the data section between chunks.
  writePending(true);
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
  writePending(true);
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
