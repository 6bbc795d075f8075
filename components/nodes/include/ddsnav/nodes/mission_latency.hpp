#pragma once
// Latencies of a mission from its recording (ddsnav bench-mission): each message reduced to when the
// recorder received it (MCAP log time, wall clock) and the key that ties it to its cause. No DDS, no files.
//
//   cloud -> obstacles   perception/obstacles carries the header of the cloud it was computed from
//   cloud -> map         map/octomap's stamp is the newest cloud inserted (so this includes its publish period)
//   request -> path      planning/path echoes planning/request's request_id
//   obstacles -> trajectory
//                        for every replan for a blocked trajectory (a request after the first whose reason
//                        starts with "trajectory_blocked"; every request after the first when no reasons were
//                        recorded — a retry after a failed plan answers no change): from the newest obstacle array
//                        received before the request to the first control/trajectory answering it, i.e.
//                        perceiving the change, deciding to replan, planning and smoothing (a replan ahead's
//                        trajectory is published when ready, stamped with its later start: docs/tracking.md);
//                        split into obstacles -> request (the replan checks and their hysteresis), request ->
//                        path and path -> trajectory (smoothing) for the same replans
//
// An effect whose cause was not recorded (dropped, or before the recording started) is skipped.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <vector>

namespace ddsnav::nodes {

struct RecordedEvent {
  std::uint64_t log_ns = 0;  // when the recorder received it
  std::int64_t key = 0;      // header stamp (clouds, obstacles, maps) or request id (requests, paths, trajectories)
};

struct MissionRecording {
  std::vector<RecordedEvent> clouds, obstacles, maps, requests, paths, trajectories;
  std::map<std::int64_t, std::string> request_reasons;  // request id -> PlanRequest.reason
};

struct LatencyStats {
  std::size_t count = 0;
  double median_ms = std::numeric_limits<double>::quiet_NaN();
  double p99_ms = std::numeric_limits<double>::quiet_NaN();  // nearest rank
  double max_ms = std::numeric_limits<double>::quiet_NaN();
};

// One replan for a blocked trajectory, for telling what its latency is made of.
struct ReplanLatency {
  std::int64_t request_id = 0;
  double obstacles_to_trajectory_ms = std::numeric_limits<double>::quiet_NaN();
  double obstacles_to_request_ms = std::numeric_limits<double>::quiet_NaN();
  // From the newest map received before the request (NaN: none): a replan that a map triggered follows it closely,
  // while the obstacle array it is counted from may be older (in 3-D, terrain is the map's).
  double map_to_request_ms = std::numeric_limits<double>::quiet_NaN();
  bool answered_by_own_trajectory = true;  // false: a later request's trajectory answered it
};

struct MissionLatencies {
  LatencyStats cloud_to_obstacles, cloud_to_map, request_to_path;
  // For each replan for a blocked trajectory: from the newest obstacles received before its request to the first
  // trajectory received after it that answers it or a later request (a plan that could not be flown is asked again,
  // and the vehicle flies the old trajectory until one answers).
  LatencyStats obstacles_to_trajectory;
  std::size_t replans_answered_later = 0;  // of them, answered by a later request's trajectory
  // The parts of obstacles_to_trajectory, over the replans their own trajectory answered.
  LatencyStats replan_obstacles_to_request, replan_request_to_path, replan_path_to_trajectory;
  std::vector<ReplanLatency> replans;  // each of obstacles_to_trajectory's, in request order
};

LatencyStats latencyStats(std::vector<double> ms);
MissionLatencies missionLatencies(const MissionRecording& recording);

}  // namespace ddsnav::nodes
