// Fuzz target: the MCAP reader as `ddsnav info` and `ddsnav play` use it, on any bytes as a file.
// Contract: McapError naming the file, or a reader whose every message can be visited.
#include "fuzz_input.hpp"

#include <ddsnav/record/info.hpp>
#include <ddsnav/record/mcap.hpp>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const ddsnav::fuzz::ScratchFile file(data, size, ".mcap");
  for (const bool force_scan : {false, true}) {  // the summary path and the crash-recovery scan
    try {
      ddsnav::record::McapReader reader(file.path(), force_scan);
      (void)ddsnav::record::formatRecordingInfo(ddsnav::record::describeRecording(reader));
      std::size_t bytes = 0;
      reader.forEachMessage([&](const ddsnav::record::MessageView& m) {
        if (m.channel == nullptr) std::abort();  // the view promises its channel
        bytes += m.data.size();
        return true;
      });
    } catch (const ddsnav::record::McapError& e) {
      ddsnav::fuzz::expectNamed(e.what(), file.path());
    }
  }
  return 0;
}
