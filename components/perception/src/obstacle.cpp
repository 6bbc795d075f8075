#include "ddsnav/perception/obstacle.hpp"

#include "ddsnav/perception/chi_square.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>
#include <stdexcept>

namespace ddsnav::perception {

double ObstacleEllipsoid::mahalanobis2(const Eigen::Vector3d& p) const {
  const Eigen::Vector3d d = p - center;
  if (dimensions == 2) {
    const Eigen::Matrix2d c = covariance.topLeftCorner<2, 2>();
    return d.head<2>().dot(c.ldlt().solve(d.head<2>()));
  }
  return d.dot(covariance.ldlt().solve(d));
}

bool ObstacleEllipsoid::contains(const Eigen::Vector3d& p) const {
  return mahalanobis2(p) <= chiSquareQuantile(probability, dimensions);
}

void updateShapeFromCovariance(ObstacleEllipsoid& e) {
  const double q = chiSquareQuantile(e.probability, e.dimensions);
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
  Eigen::Vector3d semi = Eigen::Vector3d::Zero();
  if (e.dimensions == 2) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> solver;
    solver.computeDirect(e.covariance.topLeftCorner<2, 2>());
    // Eigen sorts eigenvalues ascending; report the major axis first.
    for (int k = 0; k < 2; ++k) {
      semi[k] = std::sqrt(q * std::max(0.0, solver.eigenvalues()[1 - k]));
      axes.block<2, 1>(0, k) = solver.eigenvectors().col(1 - k);
    }
    axes.col(2) = Eigen::Vector3d::UnitZ();
  } else {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
    solver.computeDirect(e.covariance);
    for (int k = 0; k < 3; ++k) {
      semi[k] = std::sqrt(q * std::max(0.0, solver.eigenvalues()[2 - k]));
      axes.col(k) = solver.eigenvectors().col(2 - k);
    }
  }
  if (axes.determinant() < 0.0) axes.col(e.dimensions == 2 ? 1 : 2) *= -1.0;  // a proper rotation
  e.semi_axes = semi;
  e.axes = axes;
  e.orientation = Eigen::Quaterniond(axes).normalized();
}

namespace {

// Grows the covariance C (never shrinks any principal variance) until every offset d has
// d^T C^-1 d <= q. A point that sticks out mostly along one principal axis grows only that axis
// (a thin wall piece with one corner voxel gets thicker, not longer); after a few such steps any
// remaining outlier scales the whole C. Why not only the uniform scale: for a thin ellipse the
// uniform scale multiplies the long axis by the same large factor as the short one and the
// ellipse reaches metres into free space beyond the end of the piece.
template <int N>
Eigen::Matrix<double, N, N> encloseOffsets(const Eigen::Matrix<double, N, N>& covariance,
                                           const std::vector<Eigen::Vector3d>& offsets, double q) {
  using Matrix = Eigen::Matrix<double, N, N>;
  using Vector = Eigen::Matrix<double, N, 1>;
  Eigen::SelfAdjointEigenSolver<Matrix> solver;
  solver.computeDirect(covariance);
  const Matrix axes = solver.eigenvectors();
  Vector variance = solver.eigenvalues().cwiseMax(1e-12);
  auto worstPoint = [&](Vector& contributions) {
    double worst = 0.0;
    for (const auto& offset : offsets) {
      const Vector u = axes.transpose() * offset.template head<N>();
      const Vector c = u.cwiseProduct(u).cwiseQuotient(variance);
      if (c.sum() > worst) worst = c.sum(), contributions = c;
    }
    return worst;
  };
  Vector contributions = Vector::Zero();
  for (int step = 0; step < 8; ++step) {
    const double worst = worstPoint(contributions);
    if (!(worst > q)) return axes * variance.asDiagonal() * axes.transpose();
    int k = 0;
    contributions.maxCoeff(&k);
    const double rest = worst - contributions[k];
    if (!(rest < 0.9 * q)) break;  // out along several axes: scale them all
    variance[k] *= contributions[k] / (q - rest);
  }
  const double worst = worstPoint(contributions);
  if (std::isfinite(worst) && worst > q) variance *= worst / q;
  return axes * variance.asDiagonal() * axes.transpose();
}

// Shortens the major axis of an enclosing 2-D C to where the enclosed offsets end along it, plus `slack`: the
// smallest major variance that keeps every offset inside with the minor one unchanged,
//   v_major = max_j u_j,major^2 / (q - u_j,minor^2 / v_minor),
// then widened by slack (the bound ends `slack` beyond the farthest offset, so a voxel beside a tip point is inside
// too). Never lengthens. Why: along a wall piece the points are spread evenly, not as a Gaussian, and the p-bound of
// their Gaussian fit (a semi-axis of 0.88 x the piece's length against half the length where the points end) reached
// 0.56 m past the end of a 1.5 m piece — past a convex corner, into the corridor turning there (stunnel_0.5: a 2 m
// corridor, a 1 m robot, the corner closed). Beyond a piece's last point is the next piece, with its own ellipse, or
// space the same beams saw free.
Eigen::Matrix2d shortenToOffsets(const Eigen::Matrix2d& covariance, const std::vector<Eigen::Vector3d>& offsets, double q,
                                 double slack) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> solver;
  solver.computeDirect(covariance);
  const Eigen::Vector2d major = solver.eigenvectors().col(1), minor = solver.eigenvectors().col(0);
  const double v_major = solver.eigenvalues()[1], v_minor = std::max(solver.eigenvalues()[0], 1e-12);
  double needed = 0.0;
  for (const auto& offset : offsets) {
    const double along = major.dot(offset.head<2>()), across = minor.dot(offset.head<2>());
    const double room = q - across * across / v_minor;
    if (!(room > 1e-6 * q)) return covariance;  // a point on the minor bound: nothing to shorten safely
    needed = std::max(needed, along * along / room);
  }
  const double semi = std::sqrt(q * needed) + slack;
  const double shortened = semi * semi / q;
  if (!(shortened < v_major)) return covariance;
  return shortened * major * major.transpose() + v_minor * minor * minor.transpose();
}

// The fit of fitEllipsoid() over n points given by point(k) (z = 0 in 2-D) and their unit beam
// directions bearing(k) (zero vector: no range-noise term for that point).
template <class PointAt, class BearingAt>
ObstacleEllipsoid fitCore(std::size_t n, PointAt point, BearingAt bearing, int dimensions,
                          const EllipsoidFitParams& params) {
  if (dimensions != 2 && dimensions != 3) throw std::invalid_argument("fitEllipsoid: dimensions must be 2 or 3");
  if (n == 0) throw std::invalid_argument("fitEllipsoid: empty cluster");

  // Shifted sums (about the first point) keep the covariance accurate far from the world origin.
  // Both sums of outer products are symmetric: only the upper triangles are summed (the products
  // d_i d_j and d_j d_i are the same number, so this is the full product's result, bit for bit).
  const Eigen::Vector3d ref = point(0);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double oxx = 0, oxy = 0, oxz = 0, oyy = 0, oyz = 0, ozz = 0;
  double nxx = 0, nxy = 0, nxz = 0, nyy = 0, nyz = 0, nzz = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector3d d = point(k) - ref;
    sum += d;
    oxx += d.x() * d.x(), oxy += d.x() * d.y(), oxz += d.x() * d.z();
    oyy += d.y() * d.y(), oyz += d.y() * d.z(), ozz += d.z() * d.z();
    const Eigen::Vector3d u = bearing(k);
    nxx += u.x() * u.x(), nxy += u.x() * u.y(), nxz += u.x() * u.z();
    nyy += u.y() * u.y(), nyz += u.y() * u.z(), nzz += u.z() * u.z();
  }
  Eigen::Matrix3d outer, noise;
  outer << oxx, oxy, oxz, oxy, oyy, oyz, oxz, oyz, ozz;
  noise << nxx, nxy, nxz, nxy, nyy, nyz, nxz, nyz, nzz;
  const Eigen::Vector3d mean_offset = sum / static_cast<double>(n);
  Eigen::Matrix3d covariance = outer / static_cast<double>(n) - mean_offset * mean_offset.transpose();
  covariance += params.range_noise_sigma * params.range_noise_sigma / static_cast<double>(n) * noise;
  Eigen::Matrix3d quantisation = Eigen::Matrix3d::Identity() * (params.voxel_size * params.voxel_size / 12.0);
  if (dimensions == 2) {
    quantisation(2, 2) = 0.0;
    covariance.row(2).setZero();
    covariance.col(2).setZero();
  }
  covariance += quantisation;
  covariance = 0.5 * (covariance + covariance.transpose());

  const Eigen::Vector3d center = ref + mean_offset;
  if (params.enclose_points) {
    // Each point is pushed away from the centre by its own position uncertainty (3 sigma of range
    // noise plus half a voxel diagonal), so the true surface point behind it is enclosed too.
    const double q = chiSquareQuantile(params.probability, dimensions);
    const double margin = enclosingMargin(params.range_noise_sigma, params.voxel_size, dimensions);
    thread_local std::vector<Eigen::Vector3d> offsets;  // kept between fits: no allocation per fit
    offsets.resize(n);
    for (std::size_t k = 0; k < n; ++k) {
      Eigen::Vector3d d = point(k) - center;
      if (dimensions == 2) d.z() = 0.0;
      const double length = d.norm();
      offsets[k] = length > 0.0 ? Eigen::Vector3d(d * ((length + margin) / length)) : d;
    }
    if (dimensions == 2) {
      Eigen::Matrix2d grown = encloseOffsets<2>(covariance.topLeftCorner<2, 2>(), offsets, q);
      if (params.shorten_to_points) grown = shortenToOffsets(grown, offsets, q, margin);
      covariance.topLeftCorner<2, 2>() = grown;
    } else {
      covariance = encloseOffsets<3>(covariance, offsets, q);
    }
  }

  ObstacleEllipsoid e;
  e.dimensions = dimensions;
  e.center = center;
  e.covariance = covariance;
  e.probability = params.probability;
  e.point_count = n;
  updateShapeFromCovariance(e);
  return e;
}

}  // namespace

ObstacleEllipsoid fitEllipsoid(std::span<const Eigen::Vector3f> points, std::span<const int> indices,
                               const Eigen::Vector3d& sensor_origin, int dimensions,
                               const EllipsoidFitParams& params) {
  const std::size_t n = indices.empty() ? points.size() : indices.size();
  auto point = [&](std::size_t k) -> Eigen::Vector3d {
    Eigen::Vector3d p = points[indices.empty() ? k : static_cast<std::size_t>(indices[k])].cast<double>();
    if (dimensions == 2) p.z() = 0.0;
    return p;
  };
  Eigen::Vector3d origin = sensor_origin;
  if (dimensions == 2) origin.z() = 0.0;
  auto bearing = [&](std::size_t k) -> Eigen::Vector3d {
    const Eigen::Vector3d ray = point(k) - origin;
    const double range = ray.norm();
    return range > 0.0 ? Eigen::Vector3d(ray / range) : Eigen::Vector3d::Zero();
  };
  return fitCore(n, point, bearing, dimensions, params);
}

ObstacleEllipsoid fitEllipsoid(std::span<const SupportPoint> support, int dimensions,
                               const EllipsoidFitParams& params) {
  auto point = [&](std::size_t k) -> Eigen::Vector3d {
    Eigen::Vector3d p = support[k].position.cast<double>();
    if (dimensions == 2) p.z() = 0.0;
    return p;
  };
  auto bearing = [&](std::size_t k) -> Eigen::Vector3d {
    Eigen::Vector3d u = support[k].bearing.cast<double>();
    if (dimensions == 2) u.z() = 0.0;
    const double norm = u.norm();
    return norm > 0.0 ? Eigen::Vector3d(u / norm) : Eigen::Vector3d::Zero();
  };
  return fitCore(support.size(), point, bearing, dimensions, params);
}

Eigen::Matrix3f principalAxes(std::span<const Eigen::Vector3f> points, std::span<const int> indices,
                              int dimensions) {
  const std::size_t n = indices.empty() ? points.size() : indices.size();
  auto point = [&](std::size_t k) -> Eigen::Vector3d {
    Eigen::Vector3d p = points[indices.empty() ? k : static_cast<std::size_t>(indices[k])].cast<double>();
    if (dimensions == 2) p.z() = 0.0;
    return p;
  };
  Eigen::Matrix3f axes = Eigen::Matrix3f::Identity();
  if (n < 2) return axes;
  const Eigen::Vector3d ref = point(0);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector3d d = point(k) - ref;
    sum += d;
    outer.noalias() += d * d.transpose();
  }
  const Eigen::Vector3d mean = sum / static_cast<double>(n);
  const Eigen::Matrix3d covariance = outer / static_cast<double>(n) - mean * mean.transpose();
  if (dimensions == 2) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> solver;
    solver.computeDirect(covariance.topLeftCorner<2, 2>());
    const Eigen::Vector2d major = solver.eigenvectors().col(1);
    axes.block<2, 1>(0, 0) = major.cast<float>();
    axes.block<2, 1>(0, 1) = Eigen::Vector2f(-static_cast<float>(major.y()), static_cast<float>(major.x()));
    return axes;
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(covariance);
  for (int k = 0; k < 3; ++k) axes.col(k) = solver.eigenvectors().col(2 - k).cast<float>();
  if (axes.determinant() < 0.0f) axes.col(2) *= -1.0f;
  return axes;
}

namespace {

// Scratch of splitByExtent, kept per thread across calls: the split runs for every part of every scan
// (thousands per cloud), and a vector per piece and per slab was most of the detector's allocations.
struct SplitScratch {
  std::vector<int> sorted;  // one level's counting sort, copied back before the recursion
  std::vector<int> slab;    // one level's slab of each index
  std::vector<int> bounds;  // a stack: the slab boundaries of every level still being split
};

// Splits piece (a range of indices, reordered in place: each slab's indices in their original order,
// slabs in ascending order — as if each slab were a list filled in the order of piece) and appends the
// pieces to out in the order the recursion emits them.
void splitRecursive(std::span<const Eigen::Vector3f> points, std::span<int> piece, int dimensions, float max_length,
                    float max_width, int depth, Clusters& out, SplitScratch& scratch) {
  auto emit = [&] {
    out.indices.insert(out.indices.end(), piece.begin(), piece.end());
    out.offsets.push_back(static_cast<int>(out.indices.size()));
  };
  if (piece.size() < 2 || depth >= 24) return emit();
  const Eigen::Matrix3f axes = principalAxes(points, piece, dimensions);
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max()), hi = -lo;
  for (int i : piece) {
    const Eigen::Vector3f q = axes.transpose() * points[static_cast<std::size_t>(i)];
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  const Eigen::Vector3f extent = hi - lo;
  int axis = 0;
  const float longest = extent.head(dimensions).maxCoeff(&axis);
  if (!pieceTooBig(extent, dimensions, max_length, max_width)) return emit();
  // Cut across the longest extent: into pieces of at most max_length, and at least in two (a piece
  // that is short enough but too thick — an L of two faces, a strongly curved arc — is halved).
  const int slabs = std::max(2, static_cast<int>(std::ceil(longest / max_length)));
  // A stable counting sort by slab, then each non-empty slab split in turn.
  const std::size_t base = scratch.bounds.size();
  scratch.bounds.resize(base + static_cast<std::size_t>(slabs) + 1, 0);
  scratch.slab.resize(piece.size());
  for (std::size_t j = 0; j < piece.size(); ++j) {
    const float s = axes.col(axis).dot(points[static_cast<std::size_t>(piece[j])]) - lo[axis];
    const int k = std::clamp(static_cast<int>(s / longest * static_cast<float>(slabs)), 0, slabs - 1);
    scratch.slab[j] = k;
    ++scratch.bounds[base + static_cast<std::size_t>(k) + 1];
  }
  for (int k = 0; k < slabs; ++k) scratch.bounds[base + k + 1] += scratch.bounds[base + k];
  scratch.sorted.resize(piece.size());
  for (std::size_t j = 0; j < piece.size(); ++j) {  // bounds[k] is slab k's next free place
    const auto k = static_cast<std::size_t>(scratch.slab[j]);
    scratch.sorted[static_cast<std::size_t>(scratch.bounds[base + k]++)] = piece[j];
  }
  // Each slab's place ended at its end, the next slab's start: shift back by one for the starts.
  for (int k = slabs; k > 0; --k) scratch.bounds[base + k] = scratch.bounds[base + k - 1];
  scratch.bounds[base] = 0;
  std::copy(scratch.sorted.begin(), scratch.sorted.begin() + static_cast<std::ptrdiff_t>(piece.size()), piece.begin());
  for (int k = 0; k < slabs; ++k) {
    const auto first = static_cast<std::size_t>(scratch.bounds[base + k]);
    const auto last = static_cast<std::size_t>(scratch.bounds[base + k + 1]);
    if (first < last)
      splitRecursive(points, piece.subspan(first, last - first), dimensions, max_length, max_width, depth + 1, out, scratch);
  }
  scratch.bounds.resize(base);
}

}  // namespace

bool pieceTooBig(const Eigen::Vector3f& extent, int dimensions, float max_length, float max_width) {
  const float longest = extent.head(dimensions).maxCoeff();
  const float thickness = extent[dimensions - 1];  // along the last (thinnest) principal axis
  return longest > max_length || (thickness > max_width && longest > max_width);
}

void splitByExtent(std::span<const Eigen::Vector3f> points, std::span<const int> indices, int dimensions,
                   double max_length, double max_width, Clusters& out) {
  if (!(max_length > 0.0)) {
    out.indices.insert(out.indices.end(), indices.begin(), indices.end());
    out.offsets.push_back(static_cast<int>(out.indices.size()));
    return;
  }
  const double width = max_width > 0.0 ? std::min(max_width, max_length) : max_length;
  thread_local SplitScratch scratch;
  thread_local std::vector<int> piece;
  piece.assign(indices.begin(), indices.end());
  splitRecursive(points, piece, dimensions, static_cast<float>(max_length), static_cast<float>(width), 0, out, scratch);
}

double enclosingMargin(double range_noise_sigma, double voxel_size, int dimensions) {
  return 3.0 * range_noise_sigma + 0.5 * voxel_size * std::sqrt(double(dimensions));
}

}  // namespace ddsnav::perception
