// A recorded message decoded into its sample type, for the tools that replay a mission's recording offline
// (ddsnav resmooth, ddsnav-replan-replay).
#pragma once

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/record/mcap.hpp>

#include <optional>

namespace ddsnav::bench {

// The message as a T; nothing when its bytes are not a T's CDR.
template <class T>
std::optional<T> decodeRecorded(const record::MessageView& view) {
  T sample;
  if (!msg::type_support<T>().deserialize(view.data.data(), view.data.size(), &sample)) return std::nullopt;
  return sample;
}

}  // namespace ddsnav::bench
