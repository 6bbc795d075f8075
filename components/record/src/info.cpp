#include <ddsnav/record/info.hpp>

#include <fmt/format.h>

#include <set>

namespace ddsnav::record {

nlohmann::json describeRecording(McapReader& file, bool verify_chunks) {
  using nlohmann::json;
  if (verify_chunks) file.verifyChunks();
  const McapSummary& s = file.summary();
  json info;
  info["file"] = file.path();
  info["file_bytes"] = file.fileSize();
  info["library"] = file.library();
  info["truncated"] = file.truncated();
  if (file.truncated()) {
    info["truncated_at_byte"] = file.truncatedAt();
    info["truncation_reason"] = file.truncationReason();
  }
  info["indexed"] = file.hasSummary();
  info["chunks_verified"] = verify_chunks;
  json damaged = json::array();
  for (const DamagedChunk& d : file.damagedChunks()) damaged.push_back({{"offset", d.offset}, {"reason", d.reason}});
  info["damaged_chunks"] = std::move(damaged);
  info["message_count"] = s.message_count;
  const double duration = s.message_count ? static_cast<double>(s.message_end_time - s.message_start_time) * 1e-9 : 0.0;
  info["start_time_ns"] = s.message_start_time;
  info["end_time_ns"] = s.message_end_time;
  info["duration_s"] = duration;

  std::uint64_t compressed = 0, uncompressed = 0;
  std::set<std::string> compressions;
  for (const ChunkInfo& c : file.chunks()) {
    compressed += c.compressed_size;
    uncompressed += c.uncompressed_size;
    compressions.insert(c.compression.empty() ? "none" : c.compression);
  }
  info["chunks"] = {{"count", file.chunks().size()},
                    {"compression", std::vector<std::string>(compressions.begin(), compressions.end())},
                    {"compressed_bytes", compressed},
                    {"uncompressed_bytes", uncompressed},
                    {"ratio", compressed ? static_cast<double>(uncompressed) / static_cast<double>(compressed) : 0.0}};

  // Counts stored by the recorder when it closed the file (absent in a crashed recording).
  const StringMap* counts = nullptr;
  for (const Metadata& m : file.metadata()) {
    if (m.name == "ddsnav.topic_counts") counts = &m.values;
    if (m.name == "ddsnav.recording") info["recording"] = m.values;
  }
  info["topic_counts_recorded"] = counts != nullptr;
  json topics = json::array();
  for (const auto& [id, channel] : file.channels()) {
    json t;
    t["topic"] = channel.topic;
    const auto type = channel.metadata.find("dds_type");
    const auto schema = file.schemas().find(channel.schema_id);
    t["type"] = type != channel.metadata.end() ? type->second : schema != file.schemas().end() ? schema->second.name : "";
    t["schema_encoding"] = schema != file.schemas().end() ? schema->second.encoding : "";
    t["message_encoding"] = channel.message_encoding;
    if (const auto q = channel.metadata.find("qos"); q != channel.metadata.end()) t["qos"] = q->second;
    const auto n = s.channel_message_counts.find(id);
    const std::uint64_t count = n == s.channel_message_counts.end() ? 0 : n->second;
    t["message_count"] = count;
    t["rate_hz"] = duration > 0 ? static_cast<double>(count) / duration : 0.0;
    if (counts) {
      for (const char* key : {"received", "written", "dropped", "lost"}) {
        const auto v = counts->find(channel.topic + ":" + key);
        if (v != counts->end()) t[key] = std::stoull(v->second);
      }
    }
    topics.push_back(std::move(t));
  }
  info["topics"] = std::move(topics);
  return info;
}

std::string formatRecordingInfo(const nlohmann::json& info) {
  std::string out;
  out += fmt::format("file:        {} ({:.1f} MB)\n", info["file"].get<std::string>(), info["file_bytes"].get<double>() / 1e6);
  if (info["truncated"].get<bool>())
    out += fmt::format("state:       TRUNCATED at byte {} ({}); readable up to its last complete chunk\n",
                       info["truncated_at_byte"].get<std::uint64_t>(), info["truncation_reason"].get<std::string>());
  else if (info["damaged_chunks"].empty())
    out += fmt::format("state:       complete ({}{})\n", info["indexed"].get<bool>() ? "indexed summary" : "no summary, scanned",
                       info["chunks_verified"].get<bool>() ? ", every chunk verified" : "");
  if (!info["damaged_chunks"].empty()) {
    out += fmt::format("state:       DAMAGED: {} chunk(s) unreadable, their messages are skipped by play\n",
                       info["damaged_chunks"].size());
    for (const auto& d : info["damaged_chunks"])
      out += fmt::format("             chunk at byte {}: {}\n", d["offset"].get<std::uint64_t>(), d["reason"].get<std::string>());
  }
  out += fmt::format("messages:    {}\n", info["message_count"].get<std::uint64_t>());
  out += fmt::format("duration:    {:.3f} s (log time {} .. {} ns)\n", info["duration_s"].get<double>(),
                     info["start_time_ns"].get<std::uint64_t>(), info["end_time_ns"].get<std::uint64_t>());
  const auto& c = info["chunks"];
  std::string comp;
  for (const auto& x : c["compression"]) {
    if (!comp.empty()) comp += ',';
    comp += x.get<std::string>();
  }
  out += fmt::format("chunks:      {} ({}), {:.1f} MB -> {:.1f} MB, ratio {:.2f}\n", c["count"].get<std::size_t>(),
                     comp.empty() ? "-" : comp, c["uncompressed_bytes"].get<double>() / 1e6,
                     c["compressed_bytes"].get<double>() / 1e6, c["ratio"].get<double>());
  out += fmt::format("{:<28} {:<34} {:>9} {:>9} {:>9} {:>9} {:>9}\n", "topic", "type", "messages", "rate Hz", "received",
                     "lost", "dropped");
  auto count = [](const nlohmann::json& t, const char* key) {
    return t.contains(key) ? std::to_string(t[key].get<std::uint64_t>()) : std::string("-");
  };
  for (const auto& t : info["topics"]) {
    out += fmt::format("{:<28} {:<34} {:>9} {:>9.2f} {:>9} {:>9} {:>9}\n", t["topic"].get<std::string>(), t["type"].get<std::string>(),
                       t["message_count"].get<std::uint64_t>(), t["rate_hz"].get<double>(), count(t, "received"),
                       count(t, "lost"), count(t, "dropped"));
  }
  out += "(received: delivered by DDS; lost: never delivered — the jumps in each writer's sequence numbers, or the DDS\n"
         " sample-lost/rejected status; dropped: received but not written, because the recorder's queue was full or the\n"
         " file failed)\n";
  // A Cyclone DDS 0.10 reader exposes no sequence numbers, and its status misses what a reliable writer gave up on.
  if (info.contains("recording") && info["recording"].value("vendor", std::string()).find("cyclone") != std::string::npos)
    out += "(recorded with Cyclone DDS: lost is a lower bound — it cannot see samples a reliable writer overwrote before\n"
           " they arrived; record with --dds fastdds for exact counts)\n";
  if (!info["topic_counts_recorded"].get<bool>())
    out += info["truncated"].get<bool>() ? "(no per-topic received/lost/dropped counts: the recorder did not close the file)\n"
                                         : "(no per-topic received/lost/dropped counts in this file)\n";
  return out;
}

}  // namespace ddsnav::record
