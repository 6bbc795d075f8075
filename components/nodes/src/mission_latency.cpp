#include "ddsnav/nodes/mission_latency.hpp"

#include <algorithm>
#include <map>
#include <optional>

namespace ddsnav::nodes {

namespace {

// The first receipt of each key: a late duplicate (a transient-local resend) is not a new effect.
std::map<std::int64_t, std::uint64_t> firstByKey(const std::vector<RecordedEvent>& events) {
  std::map<std::int64_t, std::uint64_t> first;
  for (const auto& e : events) {
    auto [it, added] = first.emplace(e.key, e.log_ns);
    if (!added) it->second = std::min(it->second, e.log_ns);
  }
  return first;
}

double ms(std::uint64_t from, std::uint64_t to) { return (static_cast<double>(to) - static_cast<double>(from)) * 1e-6; }

// Effect - cause for every effect whose key names a recorded cause that came first.
LatencyStats keyed(const std::vector<RecordedEvent>& causes, const std::vector<RecordedEvent>& effects) {
  const auto cause = firstByKey(causes);
  std::vector<double> out;
  for (const auto& [key, at] : firstByKey(effects)) {
    const auto it = cause.find(key);
    if (it != cause.end() && at >= it->second) out.push_back(ms(it->second, at));
  }
  return latencyStats(std::move(out));
}

}  // namespace

LatencyStats latencyStats(std::vector<double> values) {
  LatencyStats s;
  s.count = values.size();
  if (values.empty()) return s;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  s.median_ms = n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
  const auto rank = static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(n)));
  s.p99_ms = values[std::max<std::size_t>(rank, 1) - 1];
  s.max_ms = values.back();
  return s;
}

MissionLatencies missionLatencies(const MissionRecording& r) {
  MissionLatencies out;
  out.cloud_to_obstacles = keyed(r.clouds, r.obstacles);
  out.cloud_to_map = keyed(r.clouds, r.maps);
  out.request_to_path = keyed(r.requests, r.paths);

  std::vector<std::uint64_t> obstacle_times, map_times;
  for (const auto& e : r.obstacles) obstacle_times.push_back(e.log_ns);
  for (const auto& e : r.maps) map_times.push_back(e.log_ns);
  std::sort(obstacle_times.begin(), obstacle_times.end());
  std::sort(map_times.begin(), map_times.end());
  const auto trajectory = firstByKey(r.trajectories);
  const auto request = firstByKey(r.requests);
  const auto path = firstByKey(r.paths);
  auto forAChange = [&](std::int64_t id) {
    if (r.request_reasons.empty()) return true;
    const auto reason = r.request_reasons.find(id);
    return reason != r.request_reasons.end() && reason->second.rfind("trajectory_blocked", 0) == 0;
  };
  std::vector<double> replans, to_request, to_path, to_trajectory;
  for (auto it = request.begin(); it != request.end(); ++it) {
    if (it == request.begin() || !forAChange(it->first)) continue;  // the first plan answers no change
    // The first trajectory after the request that answers it or a later one.
    std::optional<std::uint64_t> answered_at;
    bool own = false;
    for (auto t = trajectory.lower_bound(it->first); t != trajectory.end(); ++t)
      if (t->second >= it->second && (!answered_at || t->second < *answered_at)) answered_at = t->second, own = t->first == it->first;
    if (!answered_at) continue;
    const auto newest = std::upper_bound(obstacle_times.begin(), obstacle_times.end(), it->second);
    if (newest == obstacle_times.begin()) continue;
    const std::uint64_t perceived = *std::prev(newest);
    if (*answered_at < perceived) continue;
    replans.push_back(ms(perceived, *answered_at));
    ReplanLatency detail;
    detail.request_id = it->first;
    detail.obstacles_to_trajectory_ms = replans.back();
    detail.obstacles_to_request_ms = ms(perceived, it->second);
    if (const auto map = std::upper_bound(map_times.begin(), map_times.end(), it->second); map != map_times.begin())
      detail.map_to_request_ms = ms(*std::prev(map), it->second);
    detail.answered_by_own_trajectory = own;
    out.replans.push_back(detail);
    if (!own) {
      ++out.replans_answered_later;
      continue;
    }
    to_request.push_back(ms(perceived, it->second));
    const auto answered = path.find(it->first);
    if (answered != path.end() && answered->second >= it->second && *answered_at >= answered->second) {
      to_path.push_back(ms(it->second, answered->second));
      to_trajectory.push_back(ms(answered->second, *answered_at));
    }
  }
  out.obstacles_to_trajectory = latencyStats(std::move(replans));
  out.replan_obstacles_to_request = latencyStats(std::move(to_request));
  out.replan_request_to_path = latencyStats(std::move(to_path));
  out.replan_path_to_trajectory = latencyStats(std::move(to_trajectory));
  return out;
}

}  // namespace ddsnav::nodes
