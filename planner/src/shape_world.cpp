#include "shape_world.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ddsnav::planner::detail {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double hillHeight(const Shape& s, double d) { return s.height * std::exp(-d * d / (2.0 * s.sigma * s.sigma)); }

// Nearest point of the hill profile z = f(s), s >= 0, to (d, z) in the hill's radial half-plane.
// The vertical gap |z - f(d)| bounds the distance, so the nearest point lies in s in [d - gap, d + gap].
// Coarse samples locate the basin, golden-section search polishes it.
double hillProfileNearest(const Shape& h, double d, double z, double* s_best) {
  const double gap = std::abs(z - hillHeight(h, d));
  const double lo = std::max(0.0, d - gap);
  const double hi = d + gap;
  auto g = [&](double s) {
    const double dz = hillHeight(h, s) - z;
    return (s - d) * (s - d) + dz * dz;
  };
  constexpr int kSamples = 24;
  const double step = (hi - lo) / kSamples;
  double best_s = d, best = gap * gap;
  for (int i = 0; i <= kSamples; ++i) {
    const double s = lo + step * i;
    const double v = g(s);
    if (v < best) best = v, best_s = s;
  }
  double a = std::max(lo, best_s - step), b = std::min(hi, best_s + step);
  constexpr double kPhi = 0.6180339887498949;
  double c = b - kPhi * (b - a), e = a + kPhi * (b - a);
  double gc = g(c), ge = g(e);
  for (int i = 0; i < 40 && b - a > 1e-9; ++i) {
    if (gc < ge) {
      b = e, e = c, ge = gc, c = b - kPhi * (b - a), gc = g(c);
    } else {
      a = c, c = e, gc = ge, e = a + kPhi * (b - a), ge = g(e);
    }
  }
  const double s_mid = 0.5 * (a + b);
  const double v_mid = g(s_mid);
  if (v_mid < best) best = v_mid, best_s = s_mid;
  *s_best = best_s;
  return std::sqrt(best);
}

}  // namespace

double ellipsoidDistance(int n, const double* e, const double* y_in, double* x) {
  // Work in the first octant; signs are restored at the end.
  double y[3] = {0.0, 0.0, 0.0}, sign[3] = {1.0, 1.0, 1.0};
  double inside = 0.0;
  int k = 0;  // smallest semi-axis
  for (int i = 0; i < n; ++i) {
    sign[i] = y_in[i] < 0.0 ? -1.0 : 1.0;
    y[i] = std::abs(y_in[i]);
    inside += (y[i] / e[i]) * (y[i] / e[i]);
    if (e[i] < e[k]) k = i;
  }
  // The nearest point is x_i = e_i^2 y_i / (t + e_i^2) where t > -e_k^2 solves
  // F(t) = sum (e_i y_i / (t + e_i^2))^2 - 1 = 0. F is convex and decreasing there, so Newton from the
  // left bracket end converges monotonically; bisection guards against round-off.
  // A point exactly on the plane of the smallest axis is nudged off it so the bracket stays valid
  // (only matters for inside points, whose depth is not used for collision decisions).
  if (y[k] < 1e-12 * e[k]) y[k] = 1e-12 * e[k];
  double t_lo = -e[k] * e[k] + e[k] * y[k];
  double norm = 0.0;
  for (int i = 0; i < n; ++i) norm += e[i] * e[i] * y[i] * y[i];
  double t_hi = -e[k] * e[k] + std::sqrt(norm);
  double t = t_lo;
  for (int iter = 0; iter < 100; ++iter) {
    double f = -1.0, df = 0.0;
    for (int i = 0; i < n; ++i) {
      const double q = e[i] * y[i] / (t + e[i] * e[i]);
      f += q * q;
      df -= 2.0 * q * q / (t + e[i] * e[i]);
    }
    if (f > 0.0) t_lo = std::max(t_lo, t); else t_hi = std::min(t_hi, t);
    if (std::abs(f) < 1e-14) break;
    double next = (df < 0.0) ? t - f / df : 0.5 * (t_lo + t_hi);
    if (!(next > t_lo && next < t_hi)) next = 0.5 * (t_lo + t_hi);
    if (std::abs(next - t) <= 1e-15 * std::max(1.0, std::abs(t))) break;
    t = next;
  }
  double d2 = 0.0;
  for (int i = 0; i < n; ++i) {
    const double xi = e[i] * e[i] * y[i] / (t + e[i] * e[i]);
    d2 += (y[i] - xi) * (y[i] - xi);
    if (x) x[i] = sign[i] * xi;
  }
  const double d = std::sqrt(d2);
  return inside < 1.0 ? -d : d;
}

double signedDistance(const Shape& s, int dims, const Vec3& p, Vec3* nearest) {
  switch (s.type) {
    case ObstacleType::Sphere: {
      Vec3 v = p - s.center;
      if (dims == 2) v.z() = 0.0;
      const double n = v.norm();
      if (nearest) *nearest = s.center + (n > 0.0 ? v / n : Vec3::UnitX().eval()) * s.radius;
      return n - s.radius;
    }
    case ObstacleType::Box: {
      Vec3 q = s.axes.transpose() * (p - s.center);
      if (dims == 2) q.z() = 0.0;
      const Vec3 excess = q.cwiseAbs() - s.half;
      const int n = dims;
      double outside = 0.0, deepest = -kInf;
      int face = 0;
      for (int i = 0; i < n; ++i) {
        if (excess[i] > 0.0) outside += excess[i] * excess[i];
        if (excess[i] > deepest) deepest = excess[i], face = i;
      }
      Vec3 local = q;
      if (outside > 0.0) {
        for (int i = 0; i < n; ++i) local[i] = std::clamp(q[i], -s.half[i], s.half[i]);
      } else {
        local[face] = q[face] < 0.0 ? -s.half[face] : s.half[face];  // push out through the nearest face
      }
      if (nearest) {
        *nearest = s.center + s.axes * local;
        if (dims == 2) nearest->z() = 0.0;
      }
      return outside > 0.0 ? std::sqrt(outside) : deepest;
    }
    case ObstacleType::Ellipsoid: {
      const Vec3 q = s.axes.transpose() * (p - s.center);
      double y[3] = {q.x(), q.y(), dims == 3 ? q.z() : 0.0};
      double e[3] = {s.half.x(), s.half.y(), s.half.z()};
      double x[3] = {0.0, 0.0, 0.0};
      const double d = ellipsoidDistance(dims, e, y, x);
      if (nearest) {
        *nearest = s.center + s.axes * Vec3(x[0], x[1], x[2]);
        if (dims == 2) nearest->z() = 0.0;
      }
      return d;
    }
    case ObstacleType::Hill: {
      Eigen::Vector2d v(p.x() - s.center.x(), p.y() - s.center.y());
      const double d = v.norm();
      const Eigen::Vector2d dir = d > 0.0 ? Eigen::Vector2d(v / d) : Eigen::Vector2d(1.0, 0.0);
      double s_best = d;
      const double dist = hillProfileNearest(s, d, p.z(), &s_best);
      if (nearest) {
        *nearest = Vec3(s.center.x() + dir.x() * s_best, s.center.y() + dir.y() * s_best, hillHeight(s, s_best));
      }
      return p.z() <= hillHeight(s, d) ? -dist : dist;
    }
  }
  return kInf;
}

ShapeWorld::ShapeWorld(int dimensions, const Vec3& bounds_min, const Vec3& bounds_max, double robot_radius,
                       std::vector<Shape> shapes)
    : dims_(dimensions), bmin_(bounds_min), bmax_(bounds_max), radius_(robot_radius), shapes_(std::move(shapes)) {
  if (dims_ == 2) bmin_.z() = bmax_.z() = 0.0;
  const Vec3 grow = Vec3::Constant(radius_);
  double extent_sum = 0.0;
  for (const Shape& s : shapes_) {
    if (s.type == ObstacleType::Hill) has_ground_ = true;
    inflated_lo_.push_back(s.lo - grow);
    inflated_hi_.push_back(s.hi + grow);
    extent_sum += std::max(s.hi.x() - s.lo.x(), s.hi.y() - s.lo.y()) + 2.0 * radius_;
  }
  // Cells about the size of a typical obstacle keep each cell's list short; at most 16 cells per shape (at
  // least 1024) and 2^18 in all. Worlds are built per snapshot, and a few shapes in wide bounds asked for the
  // full 2^18 cells, three 1 MB arrays filled each time (nodes::clearFootprint's one-ellipse worlds over ±1e9 m
  // were 67 % of the tracker's CPU on gart_cluttered_2d before it built one world for all ellipses).
  const double wx = bmax_.x() - bmin_.x(), wy = bmax_.y() - bmin_.y();
  cell_size_ = shapes_.empty() ? std::max(wx, wy) : std::max(extent_sum / shapes_.size(), 1e-3);
  const double max_cells = std::clamp(16.0 * static_cast<double>(shapes_.size()), 1024.0, double(1 << 18));
  cell_size_ = std::max(cell_size_, std::sqrt(wx * wy / max_cells));
  // And at most 2^18 cells along either side: bounds of 110 x 1e33 m passed the area cap with 1.7e18 cells
  // along y, which overflowed the int cell count (UBSan, scenario fuzz target).
  cell_size_ = std::max(cell_size_, std::max(wx, wy) / double(1 << 18));
  nx_ = std::max(1, static_cast<int>(std::ceil(wx / cell_size_)));
  ny_ = std::max(1, static_cast<int>(std::ceil(wy / cell_size_)));
  std::vector<int> counts(static_cast<std::size_t>(nx_) * ny_ + 1, 0);
  auto forEachCell = [&](std::size_t i, auto&& fn) {
    const int x0 = cellX(inflated_lo_[i].x()), x1 = cellX(inflated_hi_[i].x());
    const int y0 = cellY(inflated_lo_[i].y()), y1 = cellY(inflated_hi_[i].y());
    for (int cy = y0; cy <= y1; ++cy)
      for (int cx = x0; cx <= x1; ++cx) fn(cellIndex(cx, cy));
  };
  for (std::size_t i = 0; i < shapes_.size(); ++i) forEachCell(i, [&](int c) { ++counts[c + 1]; });
  cell_start_.assign(counts.size(), 0);
  for (std::size_t c = 1; c < counts.size(); ++c) cell_start_[c] = cell_start_[c - 1] + counts[c];
  cell_items_.assign(cell_start_.back(), 0);
  std::vector<int> fill(cell_start_.begin(), cell_start_.end() - 1);
  for (std::size_t i = 0; i < shapes_.size(); ++i) forEachCell(i, [&](int c) { cell_items_[fill[c]++] = static_cast<int>(i); });
}

namespace {
// Clamped while still a double: a shape far outside the bounds (a scenario may place one there) would overflow the
// cast to int. NaN goes to cell 0.
int clampedCell(double cell, int count) {
  if (!(cell > 0.0)) return 0;
  return cell >= count - 1 ? count - 1 : static_cast<int>(cell);
}
}  // namespace

int ShapeWorld::cellX(double x) const {
  return clampedCell((x - bmin_.x()) / cell_size_, nx_);
}
int ShapeWorld::cellY(double y) const {
  return clampedCell((y - bmin_.y()) / cell_size_, ny_);
}

bool ShapeWorld::insideBounds(const Vec3& p) const {
  for (int i = 0; i < dims_; ++i) {
    if (!(p[i] - radius_ >= bmin_[i] && p[i] + radius_ <= bmax_[i])) return false;  // also rejects NaN
  }
  if (has_ground_ && p.z() - radius_ <= 0.0) return false;
  return true;
}

bool ShapeWorld::collides(const Shape& s, const Vec3& p) const {
  const double r = radius_;
  switch (s.type) {
    case ObstacleType::Sphere: {
      Vec3 v = p - s.center;
      if (dims_ == 2) v.z() = 0.0;
      return v.squaredNorm() <= (s.radius + r) * (s.radius + r);
    }
    case ObstacleType::Box: {
      const Vec3 d = p - s.center;
      // Only yaw rotations reach here from scenarios, but the general rotation costs the same.
      double outside = 0.0;
      for (int i = 0; i < dims_; ++i) {
        const double excess = std::abs(s.axes.col(i).dot(d)) - s.half[i];
        if (excess > 0.0) {
          outside += excess * excess;
          if (outside > r * r) return false;
        }
      }
      return outside <= r * r;
    }
    case ObstacleType::Ellipsoid: {
      const Vec3 q = s.axes.transpose() * (p - s.center);
      // Outside the bounding ball: free. Inside the ellipsoid with semi-axes e + r (which lies inside the
      // obstacle grown by r): collision. Otherwise solve for the exact distance.
      double grown = 0.0, emax = 0.0, qn = 0.0;
      for (int i = 0; i < dims_; ++i) {
        const double a = s.half[i] + r;
        grown += q[i] * q[i] / (a * a);
        emax = std::max(emax, s.half[i]);
        qn += q[i] * q[i];
      }
      if (qn > (emax + r) * (emax + r)) return false;
      if (grown <= 1.0) return true;
      const double y[3] = {q.x(), q.y(), q.z()};
      const double e[3] = {s.half.x(), s.half.y(), s.half.z()};
      return ellipsoidDistance(dims_, e, y, nullptr) <= r;
    }
    case ObstacleType::Hill: {
      const double dx = p.x() - s.center.x(), dy = p.y() - s.center.y();
      const double d = std::sqrt(dx * dx + dy * dy);
      // The profile decreases away from the centre: above its highest point within reach -> free;
      // the ball's lowest point under the surface -> collision; else the exact distance decides.
      if (p.z() - r > hillHeight(s, std::max(0.0, d - r))) return false;
      if (p.z() - r <= hillHeight(s, d)) return true;
      double s_best = 0.0;
      return hillProfileNearest(s, d, p.z(), &s_best) <= r;
    }
  }
  return true;
}

bool ShapeWorld::freeAgainst(const Vec3& p, const int* candidates, int count) const {
  for (int k = 0; k < count; ++k) {
    const int i = candidates[k];
    const Vec3& lo = inflated_lo_[i];
    const Vec3& hi = inflated_hi_[i];
    if (p.x() < lo.x() || p.x() > hi.x() || p.y() < lo.y() || p.y() > hi.y()) continue;
    if (dims_ == 3 && (p.z() < lo.z() || p.z() > hi.z())) continue;
    if (collides(shapes_[i], p)) return false;
  }
  return true;
}

bool ShapeWorld::isFree(const Vec3& p) const {
  countCheck();
  if (!insideBounds(p)) return false;
  const int c = cellIndex(cellX(p.x()), cellY(p.y()));
  return freeAgainst(p, cell_items_.data() + cell_start_[c], cell_start_[c + 1] - cell_start_[c]);
}

void ShapeWorld::gather(const Vec3& lo, const Vec3& hi, std::vector<int>& out) const {
  out.clear();
  const int x0 = cellX(lo.x()), x1 = cellX(hi.x()), y0 = cellY(lo.y()), y1 = cellY(hi.y());
  for (int cy = y0; cy <= y1; ++cy) {
    for (int cx = x0; cx <= x1; ++cx) {
      const int c = cellIndex(cx, cy);
      for (int k = cell_start_[c]; k < cell_start_[c + 1]; ++k) {
        const int i = cell_items_[k];
        const Vec3& a = inflated_lo_[i];
        const Vec3& b = inflated_hi_[i];
        if (a.x() > hi.x() || b.x() < lo.x() || a.y() > hi.y() || b.y() < lo.y()) continue;
        if (dims_ == 3 && (a.z() > hi.z() || b.z() < lo.z())) continue;
        out.push_back(i);
      }
    }
  }
  if (x0 != x1 || y0 != y1) {
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
  }
}

double ShapeWorld::distanceLowerBound(const Shape& s, const Vec3& p) const {
  switch (s.type) {
    case ObstacleType::Sphere: {
      Vec3 v = p - s.center;
      if (dims_ == 2) v.z() = 0.0;
      return v.norm() - s.radius;
    }
    case ObstacleType::Box: {
      const Vec3 d = p - s.center;
      double outside = 0.0;
      for (int i = 0; i < dims_; ++i) {
        const double excess = std::abs(s.axes.col(i).dot(d)) - s.half[i];
        if (excess > 0.0) outside += excess * excess;
      }
      return std::sqrt(outside);
    }
    case ObstacleType::Ellipsoid: {
      // With A = diag(1/e) and x on the ellipsoid: |Aq| - 1 <= |A(q - x)| <= |q - x| / e_min, so
      // distance >= e_min (|Aq| - 1); the bounding ball gives distance >= |q| - e_max.
      const Vec3 q = s.axes.transpose() * (p - s.center);
      double scaled = 0.0, norm = 0.0, emin = kInf, emax = 0.0;
      for (int i = 0; i < dims_; ++i) {
        scaled += q[i] * q[i] / (s.half[i] * s.half[i]);
        norm += q[i] * q[i];
        emin = std::min(emin, s.half[i]);
        emax = std::max(emax, s.half[i]);
      }
      return std::max(emin * (std::sqrt(scaled) - 1.0), std::sqrt(norm) - emax);
    }
    case ObstacleType::Hill: {
      // The profile's slope is at most L = height / sigma * exp(-1/2); for a point above a surface with
      // that Lipschitz constant, distance >= vertical gap / sqrt(1 + L^2).
      const double d = std::hypot(p.x() - s.center.x(), p.y() - s.center.y());
      const double slope = s.height / s.sigma * std::exp(-0.5);
      return (p.z() - hillHeight(s, d)) / std::sqrt(1.0 + slope * slope);
    }
  }
  return 0.0;
}

bool ShapeWorld::segmentTouches(const Shape& shape, int index, const Vec3& a, const Vec3& b,
                                std::uint64_t& evaluations) const {
  const Vec3 delta = b - a;
  const double length = delta.norm();
  if (shape.type == ObstacleType::Hill) {
    // The terrain is not convex: sample at the check resolution, skipping ahead where the cheap lower
    // bound proves the gap free. (A smooth hill bends by well under a millimetre between samples.)
    const double resolution = checkResolution();
    double travelled = 0.0;
    while (true) {
      const Vec3 p = a + (length > 0.0 ? Vec3(delta * (travelled / length)) : Vec3::Zero());
      ++evaluations;
      const double margin = distanceLowerBound(shape, p) - radius_;
      if (margin <= 0.0 && freeAgainst(p, &index, 1) == false) return true;
      if (travelled >= length) return false;
      travelled = std::min(length, travelled + std::max(resolution, margin));
    }
  }
  // Box, sphere and ellipsoid are convex, so their signed distance along the segment is a convex,
  // 1-Lipschitz (in arc length) function of t: golden-section search finds its minimum, and the search
  // stops as soon as a probe touches (distance <= radius) or the Lipschitz bound proves the rest clear.
  auto distance = [&](double t) {
    ++evaluations;
    return signedDistance(shape, dims_, a + delta * t);
  };
  const double r = radius_;
  constexpr double kPhi = 0.6180339887498949;
  constexpr double kTolerance = 1e-9;  // metres along the segment
  double lo = 0.0, hi = 1.0;
  double c = hi - kPhi * (hi - lo), d = lo + kPhi * (hi - lo);
  double fc = distance(c), fd = distance(d);
  while (true) {
    const double best = std::min(fc, fd);
    if (best <= r) return true;
    if (best - (hi - lo) * length > r) return false;  // every point of the bracket is within (hi-lo)L of a probe
    if ((hi - lo) * length < kTolerance) return false;
    if (fc < fd) {
      hi = d, d = c, fd = fc, c = hi - kPhi * (hi - lo), fc = distance(c);
    } else {
      lo = c, c = d, fc = fd, d = lo + kPhi * (hi - lo), fd = distance(d);
    }
  }
}

bool ShapeWorld::isSegmentFree(const Vec3& a, const Vec3& b) const {
  // The far end first: most rejected edges fail there.
  if (!isFree(b)) return false;
  // The shrunk bounds box (and the half-space above the ground) is convex: both ends inside means the
  // whole segment is.
  countCheck();
  if (!insideBounds(a)) return false;
  thread_local std::vector<int> near;
  gather(a.cwiseMin(b), a.cwiseMax(b), near);
  std::uint64_t evaluations = 0;
  bool touches = false;
  for (int i : near) {
    // Cheap rejection: the shape's lower bound at the midpoint minus half the length exceeds the radius.
    const double half = 0.5 * (b - a).norm();
    if (distanceLowerBound(shapes_[i], 0.5 * (a + b)) - half > radius_) continue;
    if (segmentTouches(shapes_[i], i, a, b, evaluations)) {
      touches = true;
      break;
    }
  }
  countCheck(evaluations);
  return !touches;
}

double ShapeWorld::clearance(const Vec3& p) const {
  // Rings of grid cells around p's cell, nearest first. Once rings 0..k-1 are done, every obstacle not yet
  // seen has its (robot-grown) bounds outside a block reaching at least (k-1) cells from p in every
  // direction, so it is at least (k-1) * cell away: the search stops when the best distance is within that.
  double best = has_ground_ ? p.z() : kInf;
  thread_local std::vector<std::uint32_t> seen;
  thread_local std::uint32_t stamp = 0;
  if (seen.size() < shapes_.size()) seen.assign(shapes_.size(), 0);
  if (++stamp == 0) std::fill(seen.begin(), seen.end(), 0), stamp = 1;
  const int cx = cellX(p.x()), cy = cellY(p.y());
  const int max_ring = std::max(std::max(cx, nx_ - 1 - cx), std::max(cy, ny_ - 1 - cy));
  for (int k = 0; k <= max_ring; ++k) {
    if (k > 0 && best <= (k - 1) * cell_size_) break;
    for (int y = cy - k; y <= cy + k; ++y) {
      if (y < 0 || y >= ny_) continue;
      const bool edge_row = y == cy - k || y == cy + k;
      for (int x = cx - k; x <= cx + k; x += (edge_row || k == 0) ? 1 : 2 * k) {
        if (x < 0 || x >= nx_) continue;
        const int c = cellIndex(x, y);
        for (int j = cell_start_[c]; j < cell_start_[c + 1]; ++j) {
          const int i = cell_items_[j];
          if (seen[i] == stamp) continue;
          seen[i] = stamp;
          best = std::min(best, signedDistance(shapes_[i], dims_, p));
        }
      }
    }
  }
  return best - radius_;
}

std::vector<NearbyObstacle> ShapeWorld::obstaclesNear(const Vec3& p, double range) const {
  std::vector<NearbyObstacle> found;
  if (!(range >= 0.0)) return found;
  const Vec3 reach = Vec3::Constant(std::min(range, 1e15));
  thread_local std::vector<int> near;
  gather(p - reach, p + reach, near);
  for (int i : near) {
    NearbyObstacle o;
    o.id = shapes_[i].id;
    const double d = signedDistance(shapes_[i], dims_, p, &o.nearest_point);
    if (d > range) continue;
    o.distance = std::max(0.0, d);
    found.push_back(o);
  }
  std::sort(found.begin(), found.end(), [](const NearbyObstacle& x, const NearbyObstacle& y) {
    return x.distance != y.distance ? x.distance < y.distance : x.id < y.id;
  });
  return found;
}

}  // namespace ddsnav::planner::detail
