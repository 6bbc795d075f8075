// What `ddsnav info` reports about a recording, as JSON (the --json output) and as text.
#pragma once

#include <ddsnav/record/mcap.hpp>

#include <nlohmann/json.hpp>

#include <string>

namespace ddsnav::record {

// Topics (type, count, rate, recorded drops), time range, chunks and compression, truncation.
nlohmann::json describeRecording(const McapReader& file);
std::string formatRecordingInfo(const nlohmann::json& info);

}  // namespace ddsnav::record
