// What `ddsnav info` reports about a recording, as JSON (the --json output) and as text.
#pragma once

#include <ddsnav/record/mcap.hpp>

#include <nlohmann/json.hpp>

#include <string>

namespace ddsnav::record {

// Topics (type, count, rate, recorded losses and drops), time range, chunks and compression, truncation,
// damaged chunks. verify_chunks: decompress and CRC-check every chunk first (McapReader::verifyChunks), so
// a file whose summary is intact but whose data is not is not called complete.
nlohmann::json describeRecording(McapReader& file, bool verify_chunks = true);
std::string formatRecordingInfo(const nlohmann::json& info);

}  // namespace ddsnav::record
