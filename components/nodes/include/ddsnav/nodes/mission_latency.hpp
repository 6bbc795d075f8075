#pragma once
// Latencies of a mission from its recording (ddsnav bench-mission): each message reduced to when the
// recorder received it (MCAP log time, wall clock) and the key that ties it to its cause. No DDS, no files.
//
//   cloud -> obstacles   perception/obstacles carries the header of the cloud it was computed from
//   cloud -> map         map/octomap's stamp is the newest cloud inserted (so this includes its publish period)
//   request -> path      planning/path echoes planning/request's request_id
//   obstacles -> trajectory
//                        for every replan (every request after the first): from the newest obstacle array
//                        received before the request to the first control/trajectory answering it, i.e.
//                        perceiving the change, deciding to replan, planning and smoothing
//
// An effect whose cause was not recorded (dropped, or before the recording started) is skipped.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace ddsnav::nodes {

struct RecordedEvent {
  std::uint64_t log_ns = 0;  // when the recorder received it
  std::int64_t key = 0;      // header stamp (clouds, obstacles, maps) or request id (requests, paths, trajectories)
};

struct MissionRecording {
  std::vector<RecordedEvent> clouds, obstacles, maps, requests, paths, trajectories;
};

struct LatencyStats {
  std::size_t count = 0;
  double median_ms = std::numeric_limits<double>::quiet_NaN();
  double p99_ms = std::numeric_limits<double>::quiet_NaN();  // nearest rank
  double max_ms = std::numeric_limits<double>::quiet_NaN();
};

struct MissionLatencies {
  LatencyStats cloud_to_obstacles, cloud_to_map, request_to_path, obstacles_to_trajectory;
};

LatencyStats latencyStats(std::vector<double> ms);
MissionLatencies missionLatencies(const MissionRecording& recording);

}  // namespace ddsnav::nodes
