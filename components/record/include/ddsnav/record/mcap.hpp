// MCAP files (https://mcap.dev/spec), written and read from the specification: the container ddsnav
// records DDS traffic in. No DDS here: channels carry opaque payloads (for ddsnav, XCDR1 bytes).
//
//   record::McapWriter w("run.mcap", {.compression = record::Compression::Zstd});
//   auto schema = w.addSchema("ddsnav::msg::Path", "omgidl", idl_text);
//   auto channel = w.addChannel(schema, "planning/path", "cdr", {{"keyed", "false"}});
//   w.write(channel, log_time_ns, publish_time_ns, bytes);
//   w.close();  // summary + footer; without it (a crash) the file still reads up to its last chunk
//
//   record::McapReader r("run.mcap");       // throws McapError naming the file and byte offset
//   r.forEachMessage([](const record::MessageView& m) { ... });
//
// Layout written: magic, Header, then per data: Schema/Channel records as they appear (outside chunks, so
// a truncated file knows every channel before its messages), Chunks (messages only) each followed by its
// MessageIndex records, Metadata; then DataEnd, the summary (Schema, Channel, Statistics, ChunkIndex,
// MetadataIndex), SummaryOffset records, Footer, magic.
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <memory>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace ddsnav::record {

// A file that is not MCAP, or is damaged: the message names the file and the byte offset.
class McapError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class Compression { None, Zstd, Lz4 };
std::string_view compressionName(Compression c);  // "" | "zstd" | "lz4" (the spec's names; lz4: the LZ4 frame format)
// Raises the calling thread's nice value by `increment` (lower priority; Linux per-thread nice).
void lowerThreadPriority(int increment);

using StringMap = std::map<std::string, std::string>;

struct Schema {
  std::uint16_t id = 0;
  std::string name;      // for ddsnav: the DDS type name, e.g. "ddsnav::msg::Path"
  std::string encoding;  // "omgidl"
  std::string data;      // the IDL text defining the type
};

struct Channel {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;
  std::string topic;
  std::string message_encoding;  // "cdr"
  StringMap metadata;
};

struct MessageView {
  const Channel* channel = nullptr;
  std::uint32_t sequence = 0;
  std::uint64_t log_time = 0;      // ns; for ddsnav: when the recorder received it
  std::uint64_t publish_time = 0;  // ns; for ddsnav: the writer's source timestamp
  std::span<const std::uint8_t> data;
};

struct Metadata {
  std::string name;
  StringMap values;
};

struct ChunkInfo {
  std::uint64_t offset = 0;  // of the Chunk record in the file
  std::uint64_t record_length = 0;  // whole record: opcode + length + content
  std::uint64_t message_start_time = 0;
  std::uint64_t message_end_time = 0;
  std::uint64_t compressed_size = 0;
  std::uint64_t uncompressed_size = 0;
  std::string compression;
  std::map<std::uint16_t, std::uint64_t> message_index_offsets;  // channel -> MessageIndex record offset
  std::uint64_t message_index_length = 0;  // bytes of the MessageIndex records after the chunk
};

// A chunk whose records cannot be used (CRC mismatch, does not decompress, impossible sizes).
struct DamagedChunk {
  std::uint64_t offset = 0;  // of the Chunk record
  std::string reason;        // the reader's error, naming file and offset
};

// Largest uncompressed chunk the reader accepts. The size is read from the file, so it is checked before
// anything is allocated; ddsnav writes chunks of --chunk-kb (at most 1 GiB) plus one message.
inline constexpr std::uint64_t kMaxChunkUncompressedBytes = 1ull << 30;

struct McapWriterOptions {
  Compression compression = Compression::Zstd;
  int zstd_level = 1;                      // fast: recording must keep up with the sensors
  // LZ4 frame compression level: 0 default (fast), < 0 faster still ("acceleration"), > 2 LZ4-HC (slow).
  int lz4_level = 0;
  std::size_t chunk_size = 1 << 20;        // close a chunk once its records reach this many bytes
  std::chrono::milliseconds chunk_age{1000};  // ... or once its first message is this old (flushAged)
  std::string profile;                     // MCAP profile; "" (ddsnav's schemas are OMG IDL, not ROS)
  std::string library = "ddsnav-record";
  // Closed chunks are CRC'd and compressed by this many worker threads while the caller fills the next
  // one (0: on the calling thread). Chunks still reach the file in order.
  unsigned compression_threads = 0;
  // Closed chunks waiting for a worker or for their turn to be written; closing one more waits.
  std::size_t max_pending_chunks = 4;
  // Added to the workers' nice value: a recorder's workers yield the CPU to the threads receiving data.
  int worker_nice = 0;
};

class McapWriter {
  struct PendingChunk;
  struct Compressor;
  class Pool;

 public:
  // Creates (truncates) the file and writes magic + Header. Throws McapError when it cannot.
  McapWriter(const std::string& path, McapWriterOptions options = {});
  ~McapWriter();  // closes if still open (errors are logged to stderr, not thrown)
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  std::uint16_t addSchema(const std::string& name, const std::string& encoding, const std::string& data);
  std::uint16_t addChannel(std::uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                           const StringMap& metadata = {});
  // Sequence numbers count per channel from 1. The bytes are copied into the open chunk.
  void write(std::uint16_t channel_id, std::uint64_t log_time, std::uint64_t publish_time,
             std::span<const std::uint8_t> data);
  // The same, taking the buffer: a payload of at least kAttachBytes is not copied but kept with its
  // chunk (CRC, compression and the file write read it where it is) until the chunk is in the file. The
  // buffer then comes back through takeReleasedBuffers(), for the caller to reuse.
  void write(std::uint16_t channel_id, std::uint64_t log_time, std::uint64_t publish_time,
             std::vector<std::uint8_t>&& data);
  static constexpr std::size_t kAttachBytes = 64 * 1024;
  // Payload buffers given to write(&&) that are no longer needed (their chunk is written, or they were
  // small enough to copy), emptied but with their capacity.
  std::vector<std::vector<std::uint8_t>> takeReleasedBuffers();
  void addMetadata(const std::string& name, const StringMap& values);
  // Closes the open chunk (if any) when its first message is older than options.chunk_age.
  void flushAged();
  // Closes the open chunk and hands the bytes to the OS: a crash after this loses nothing written before.
  void flush();
  // Writes the chunks the workers have finished (in order), without waiting for the others.
  void writeFinishedChunks();
  void close();
  bool isOpen() const { return file_ != nullptr; }

  std::uint64_t messageCount() const { return message_count_; }
  std::uint64_t bytesWritten() const { return position_; }
  // Bytes of message records not yet in the file: the open chunk and closed chunks waiting for a worker.
  std::uint64_t bytesBuffered() const;
  // Messages per channel written with write() but not (yet) in the file. After a write error, these are
  // the ones the failure lost.
  std::map<std::uint16_t, std::uint64_t> unwrittenMessages() const;
  std::size_t chunkCount() const { return chunks_.size(); }

 private:
  void writeRecord(std::uint8_t opcode, const std::vector<std::uint8_t>& content);
  void writeBytes(const void* data, std::size_t size);
  void flushFile();
  void closeChunk();
  void writePending(bool wait_all);
  void writeChunk(PendingChunk& chunk);
  void appendMessageHeader(std::uint16_t channel_id, std::uint64_t log_time, std::uint64_t publish_time, std::size_t size);
  void afterMessage(std::uint16_t channel_id, std::uint64_t log_time);
  std::uint64_t openChunkBytes() const { return chunk_records_.size() + chunk_attached_bytes_; }

  std::string path_;
  McapWriterOptions options_;
  std::FILE* file_ = nullptr;
  std::uint64_t position_ = 0;
  std::vector<Schema> schemas_;
  std::vector<Channel> channels_;
  std::vector<std::uint32_t> sequences_;                 // per channel
  std::map<std::uint16_t, std::uint64_t> channel_counts_;
  std::uint64_t message_count_ = 0;
  std::uint64_t start_time_ = 0, end_time_ = 0;
  // The open chunk: its bytes are chunk_records_ with each attached payload inserted at its offset.
  std::vector<std::uint8_t> chunk_records_;
  struct Attached {
    std::size_t at;  // offset in chunk_records_ where these bytes belong
    std::vector<std::uint8_t> bytes;
  };
  std::vector<Attached> chunk_attached_;
  std::uint64_t chunk_attached_bytes_ = 0;
  std::vector<std::vector<std::uint8_t>> released_;  // payload buffers for takeReleasedBuffers()
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index_;  // channel -> (time, offset)
  std::uint64_t chunk_start_ = 0, chunk_end_ = 0;
  std::chrono::steady_clock::time_point chunk_opened_;
  std::vector<ChunkInfo> chunks_;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> metadata_offsets_;  // offset, length
  std::vector<std::string> metadata_names_;
  std::unique_ptr<Pool> pool_;                              // compression workers, or none
  std::deque<std::shared_ptr<PendingChunk>> pending_;      // closed, not yet written, in file order
  std::vector<std::vector<std::uint8_t>> spare_buffers_;    // chunk buffers to reuse
  std::unique_ptr<Compressor> compressor_;  // of the calling thread (compression_threads == 0)
};

struct McapSummary {
  std::uint64_t message_count = 0;
  std::uint64_t message_start_time = 0;
  std::uint64_t message_end_time = 0;
  std::map<std::uint16_t, std::uint64_t> channel_message_counts;
};

class McapReader {
 public:
  // Reads the summary when the file has a valid one; otherwise (a crashed recording) scans the records
  // from the start and keeps everything up to the first incomplete record. A damaged chunk whose record
  // length is sound is remembered (damagedChunks()) and skipped; the scan goes on after it.
  // Refuses anything but a regular file (a FIFO would block, a directory has no bytes) with McapError.
  // force_scan: ignore the summary (tests compare both paths).
  explicit McapReader(const std::string& path, bool force_scan = false);
  ~McapReader();
  McapReader(const McapReader&) = delete;
  McapReader& operator=(const McapReader&) = delete;

  const std::string& path() const { return path_; }
  std::uint64_t fileSize() const { return file_size_; }
  const std::string& profile() const { return profile_; }
  const std::string& library() const { return library_; }
  bool hasSummary() const { return has_summary_; }
  // True when the file ends early (no footer or an incomplete record): the recorder did not close it.
  bool truncated() const { return truncated_; }
  std::uint64_t truncatedAt() const { return truncated_at_; }   // offset of the first unusable byte
  const std::string& truncationReason() const { return truncation_reason_; }

  const std::map<std::uint16_t, Schema>& schemas() const { return schemas_; }
  const std::map<std::uint16_t, Channel>& channels() const { return channels_; }
  const std::vector<ChunkInfo>& chunks() const { return chunks_; }
  const std::vector<Metadata>& metadata() const { return metadata_; }
  // From the Statistics record, or counted while scanning.
  const McapSummary& summary() const { return summary_; }

  // Damaged chunks found so far: while scanning, or by verifyChunks().
  const std::vector<DamagedChunk>& damagedChunks() const { return damaged_; }
  // Decompresses and CRC-checks every chunk (a summary does not say whether the data behind it is
  // intact); returns damagedChunks().
  const std::vector<DamagedChunk>& verifyChunks();

  using DamagedChunkHandler = std::function<void(const DamagedChunk&)>;
  // Every message in file order (for ddsnav recordings: log-time order). The view's data is valid during
  // the callback. Return false from the callback to stop. A damaged chunk throws McapError, or, when
  // on_damaged is given, is reported to it and skipped: reading goes on with the next chunk.
  void forEachMessage(const std::function<bool(const MessageView&)>& callback,
                      const DamagedChunkHandler& on_damaged = {}) const;

 private:
  void readSummary(std::uint64_t summary_start, std::uint64_t summary_offset_start);
  std::uint64_t indexedChunkMessages() const;  // messages the chunks' MessageIndex records list (0: unknown)
  void findLooseMessages(std::uint64_t summary_start);
  void scan();
  std::vector<std::uint8_t> readAt(std::uint64_t offset, std::uint64_t size) const;
  std::vector<std::uint8_t> chunkRecords(const ChunkInfo& chunk) const;
  [[noreturn]] void fail(std::uint64_t offset, const std::string& what) const;

  std::string path_;
  std::FILE* file_ = nullptr;
  std::uint64_t file_size_ = 0;
  std::string profile_, library_;
  bool has_summary_ = false;
  bool truncated_ = false;
  std::uint64_t truncated_at_ = 0;
  std::string truncation_reason_;
  std::map<std::uint16_t, Schema> schemas_;
  std::map<std::uint16_t, Channel> channels_;
  std::vector<ChunkInfo> chunks_;
  std::vector<std::uint64_t> loose_messages_;  // offsets of Message records outside chunks
  std::vector<Metadata> metadata_;
  std::vector<DamagedChunk> damaged_;
  McapSummary summary_;
};

}  // namespace ddsnav::record
