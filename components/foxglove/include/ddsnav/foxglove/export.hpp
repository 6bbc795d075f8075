// `ddsnav export --foxglove`: a copy of a recording with the derived Foxglove channels added
// (derived.hpp), so it opens in Foxglove with a ready 3D view. The recorded channels and messages are
// copied unchanged; each derived message is written right after its source, with the source's log time.
// No DDS.
#pragma once

#include <ddsnav/foxglove/derived.hpp>
#include <ddsnav/foxglove/svg.hpp>
#include <ddsnav/record/mcap.hpp>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace ddsnav::foxglove {

struct ExportStats {
  std::uint64_t copied = 0;                          // recorded messages copied
  std::map<std::string, std::uint64_t> derived;      // derived topic -> messages written
  std::uint64_t failed = 0;                          // source messages that could not be converted
  std::vector<std::string> first_errors;             // the first few conversion errors, verbatim
};

// Writes `out` from `in`. Conversion errors of single messages are counted, not fatal (a recording of
// a run with one bad message is still worth looking at); I/O errors throw record::McapError. `picture`,
// when given, receives every derived SceneUpdate (the final scene: SceneSvg::render).
ExportStats exportFoxglove(const record::McapReader& in, record::McapWriter& out, SceneDeriverOptions options = {},
                           SceneSvg* picture = nullptr);

// Adds the JSON Schema of `schema_name` and a json channel on `topic` to `out`; returns the channel id.
// Shared by the exporter and `ddsnav record --foxglove`.
std::uint16_t addDerivedChannel(record::McapWriter& out, const DerivedChannel& channel);

}  // namespace ddsnav::foxglove
