#include "ddsnav/tracker/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace ddsnav::tracker {

BSpline BSpline::clampedUniform(std::vector<Vec3> control_points) {
  if (control_points.size() < kDegree + 1)
    throw std::invalid_argument("BSpline: a cubic B-spline needs at least 4 control points");
  BSpline s;
  const int n = static_cast<int>(control_points.size());
  s.control_points = std::move(control_points);
  const int spans = n - kDegree;
  s.knots.reserve(n + kDegree + 1);
  for (int i = 0; i < kDegree; ++i) s.knots.push_back(0.0);
  for (int i = 0; i <= spans; ++i) s.knots.push_back(static_cast<double>(i));
  for (int i = 0; i < kDegree; ++i) s.knots.push_back(static_cast<double>(spans));
  return s;
}

int BSpline::firstControlPoint(double u) const {
  const int n = static_cast<int>(control_points.size()) - 1;
  int span;
  if (u >= knots[n + 1]) {
    span = n;
  } else if (u <= knots[kDegree]) {
    span = kDegree;
  } else {
    // The span with knots[span] <= u < knots[span + 1].
    auto it = std::upper_bound(knots.begin() + kDegree, knots.begin() + n + 2, u);
    span = static_cast<int>(it - knots.begin()) - 1;
  }
  return span - kDegree;
}

// Basis functions and their first two derivatives (the NURBS Book's algorithm A2.3, for degree 3).
void BSpline::evaluate(double u, Vec3& position, Vec3& first, Vec3& second) const {
  constexpr int p = kDegree;
  const int first_cp = firstControlPoint(u);
  const int span = first_cp + p;
  u = std::clamp(u, parameterMin(), parameterMax());
  const auto& U = knots;

  double ndu[p + 1][p + 1];
  double left[p + 1], right[p + 1];
  ndu[0][0] = 1.0;
  for (int j = 1; j <= p; ++j) {
    left[j] = u - U[span + 1 - j];
    right[j] = U[span + j] - u;
    double saved = 0.0;
    for (int r = 0; r < j; ++r) {
      ndu[j][r] = right[r + 1] + left[j - r];
      const double temp = ndu[j][r] != 0.0 ? ndu[r][j - 1] / ndu[j][r] : 0.0;
      ndu[r][j] = saved + right[r + 1] * temp;
      saved = left[j - r] * temp;
    }
    ndu[j][j] = saved;
  }
  double ders[3][p + 1];
  for (int j = 0; j <= p; ++j) ders[0][j] = ndu[j][p];
  double a[2][p + 1];
  for (int r = 0; r <= p; ++r) {
    int s1 = 0, s2 = 1;
    a[0][0] = 1.0;
    for (int k = 1; k <= 2; ++k) {
      double d = 0.0;
      const int rk = r - k, pk = p - k;
      if (r >= k) {
        a[s2][0] = a[s1][0] / ndu[pk + 1][rk];
        d = a[s2][0] * ndu[rk][pk];
      }
      const int j1 = rk >= -1 ? 1 : -rk;
      const int j2 = (r - 1 <= pk) ? k - 1 : p - r;
      for (int j = j1; j <= j2; ++j) {
        a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][rk + j];
        d += a[s2][j] * ndu[rk + j][pk];
      }
      if (r <= pk) {
        a[s2][k] = -a[s1][k - 1] / ndu[pk + 1][r];
        d += a[s2][k] * ndu[r][pk];
      }
      ders[k][r] = d;
      std::swap(s1, s2);
    }
  }
  double factor = p;
  for (int k = 1; k <= 2; ++k) {
    for (int j = 0; j <= p; ++j) ders[k][j] *= factor;
    factor *= (p - k);
  }
  position.setZero();
  first.setZero();
  second.setZero();
  for (int j = 0; j <= p; ++j) {
    const Vec3& cp = control_points[first_cp + j];
    position += ders[0][j] * cp;
    first += ders[1][j] * cp;
    second += ders[2][j] * cp;
  }
}

Vec3 BSpline::point(double u) const {
  Vec3 p, d1, d2;
  evaluate(u, p, d1, d2);
  return p;
}

Vec3 TrajectorySample::velocity() const {
  return {speed * std::cos(heading), speed * std::sin(heading), vz};
}

TrajectorySample Trajectory::at(double time) const {
  if (samples.empty()) throw std::logic_error("Trajectory::at on an empty trajectory");
  if (time <= samples.front().time) return samples.front();
  if (time >= samples.back().time) return samples.back();
  auto it = std::upper_bound(samples.begin(), samples.end(), time,
                             [](double t, const TrajectorySample& s) { return t < s.time; });
  const TrajectorySample& b = *it;
  const TrajectorySample& a = *(it - 1);
  const double f = (time - a.time) / (b.time - a.time);
  TrajectorySample out;
  out.time = time;
  out.position = a.position + f * (b.position - a.position);
  out.heading = a.heading + f * (b.heading - a.heading);
  out.speed = a.speed + f * (b.speed - a.speed);
  out.yaw_rate = a.yaw_rate + f * (b.yaw_rate - a.yaw_rate);
  out.vz = a.vz + f * (b.vz - a.vz);
  out.curvature = a.curvature + f * (b.curvature - a.curvature);
  out.arc_length = a.arc_length + f * (b.arc_length - a.arc_length);
  return out;
}

namespace {

// Where arc length s falls among non-empty samples: between samples[index - 1] and samples[index] at fraction f
// (index 0 or f = 1 at the ends, clamped).
struct ArcPosition {
  std::size_t index = 0;
  double f = 0.0;
};
ArcPosition locateArc(const std::vector<TrajectorySample>& in, double s) {
  auto it = std::lower_bound(in.begin(), in.end(), s, [](const TrajectorySample& x, double v) { return x.arc_length < v; });
  if (it == in.begin()) return {0, 0.0};
  if (it == in.end()) return {in.size() - 1, 1.0};
  const TrajectorySample& b = *it;
  const TrajectorySample& a = *(it - 1);
  return {static_cast<std::size_t>(it - in.begin()), b.arc_length > a.arc_length ? (s - a.arc_length) / (b.arc_length - a.arc_length) : 1.0};
}

}  // namespace

double timeAtArcLength(const Trajectory& trajectory, double s) {
  const auto& in = trajectory.samples;
  if (in.empty()) return 0.0;
  const ArcPosition at = locateArc(in, s);
  if (at.index == 0) return in.front().time;
  return in[at.index - 1].time + at.f * (in[at.index].time - in[at.index - 1].time);
}

double brakingDecel(double speed, double room, double comfortable, double limit) {
  if (!(speed > 0.0)) return comfortable;
  if (!(room > 0.0)) return limit;
  return std::clamp(speed * speed / (2.0 * room), comfortable, std::max(comfortable, limit));
}

Trajectory brakeAlong(const Trajectory& trajectory, double from_time, double speed, double decel) {
  if (trajectory.samples.empty()) throw std::invalid_argument("brakeAlong: empty trajectory");
  if (!std::isfinite(speed) || speed < 0.0) throw std::invalid_argument("brakeAlong: speed must be finite and >= 0");
  if (!std::isfinite(decel) || !(decel > 0.0)) throw std::invalid_argument("brakeAlong: decel must be positive");
  const double dt = trajectory.dt > 0.0 ? trajectory.dt : 0.05;
  const auto& in = trajectory.samples;
  const double s0 = trajectory.at(from_time).arc_length;
  const double s_end = in.back().arc_length;
  // The original sample at arc length s (interpolated), for the path's geometry there.
  const auto atArc = [&](double s) {
    const ArcPosition at = locateArc(in, s);
    if (at.index == 0) return in.front();
    const TrajectorySample& a = in[at.index - 1];
    const TrajectorySample& b = in[at.index];
    const double f = at.f;
    TrajectorySample out = f < 0.5 ? a : b;
    out.position = a.position + f * (b.position - a.position);
    out.heading = a.heading + f * (b.heading - a.heading);
    out.curvature = a.curvature + f * (b.curvature - a.curvature);
    return out;
  };
  Trajectory out;
  out.dimensions = trajectory.dimensions;
  out.dt = dt;
  out.curve = trajectory.curve;
  const double stop_time = speed / decel;
  for (int k = 0;; ++k) {
    double t = k * dt;
    bool last = t >= stop_time;
    if (last) t = stop_time;
    double s = s0 + speed * t - 0.5 * decel * t * t;
    if (s >= s_end) s = s_end, last = true;
    TrajectorySample sample = atArc(s);
    const double v_path = last ? 0.0 : std::max(0.0, speed - decel * t);  // along the path
    // The path's own split of its speed into horizontal and vertical parts (a climb in 3-D).
    const double along = std::hypot(sample.speed, sample.vz);
    const double horizontal = along > 1e-9 ? sample.speed / along : 1.0, vertical = along > 1e-9 ? sample.vz / along : 0.0;
    sample.time = t;
    sample.speed = v_path * horizontal;
    sample.vz = v_path * vertical;
    sample.yaw_rate = sample.curvature * sample.speed;
    sample.arc_length = s - s0;
    if (!out.samples.empty() && t <= out.samples.back().time) break;  // a stop from rest: one sample only
    out.samples.push_back(sample);
    if (last) break;
  }
  if (out.samples.size() == 1) {  // already at rest: hold the position
    TrajectorySample hold = out.samples.front();
    hold.time = dt;
    out.samples.push_back(hold);
  }
  return out;
}

std::string takeOverRefusal(const Trajectory& trajectory, double arrival_speed, double max_decel, double omega_max,
                            double flown_through, double at_rest, double slack, double vz_max) {
  if (!(arrival_speed > flown_through) || trajectory.samples.empty()) return {};
  const double start = trajectory.samples.front().speed;
  if (start < at_rest) return "it starts at rest: the vehicle would overshoot its start";
  if (start >= arrival_speed - slack) return {};
  const double arc0 = trajectory.samples.front().arc_length;
  char why[200];
  for (const auto& sample : trajectory.samples) {
    const double vehicle = std::sqrt(std::max(0.0, arrival_speed * arrival_speed - 2.0 * max_decel * (sample.arc_length - arc0)));
    if (vehicle <= sample.speed + slack) return {};  // down to the trajectory's speed: its reference has caught up
    const double on = sample.arc_length - arc0;
    if (sample.speed < at_rest) {
      std::snprintf(why, sizeof why, "braking, the vehicle would meet a stop %.1f m on at %.1f m/s", on, vehicle);
      return why;
    }
    if (vehicle * std::abs(sample.curvature) > omega_max) {
      std::snprintf(why, sizeof why, "braking, the vehicle would reach a curve of %.3f 1/m %.1f m on at %.1f m/s (%.2f rad/s, more than %.2f)",
                    std::abs(sample.curvature), on, vehicle, vehicle * std::abs(sample.curvature), omega_max);
      return why;
    }
    // The same climb at the vehicle's speed: vz grows with it, and a vehicle that cannot climb that fast flies under it.
    if (vehicle * std::abs(sample.vz) > vz_max * sample.speed) {
      std::snprintf(why, sizeof why, "braking, the vehicle would reach a slope of %.2f %.1f m on at %.1f m/s (vz %.2f m/s, more than %.2f)",
                    std::abs(sample.vz) / sample.speed, on, vehicle, vehicle * std::abs(sample.vz) / sample.speed, vz_max);
      return why;
    }
  }
  return {};
}

bool cannotTakeOver(const Trajectory& trajectory, double arrival_speed, double max_decel, double omega_max,
                    double flown_through, double at_rest, double slack, double vz_max) {
  return !takeOverRefusal(trajectory, arrival_speed, max_decel, omega_max, flown_through, at_rest, slack, vz_max).empty();
}

}  // namespace ddsnav::tracker
