#include "ddsnav/perception/obstacle.hpp"

#include "ddsnav/perception/chi_square.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
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

ObstacleEllipsoid fitEllipsoid(std::span<const Eigen::Vector3f> points, std::span<const int> indices,
                               const Eigen::Vector3d& sensor_origin, int dimensions,
                               const EllipsoidFitParams& params) {
  if (dimensions != 2 && dimensions != 3) throw std::invalid_argument("fitEllipsoid: dimensions must be 2 or 3");
  const std::size_t n = indices.empty() ? points.size() : indices.size();
  if (n == 0) throw std::invalid_argument("fitEllipsoid: empty cluster");
  auto point = [&](std::size_t k) -> Eigen::Vector3d {
    Eigen::Vector3d p = points[indices.empty() ? k : static_cast<std::size_t>(indices[k])].cast<double>();
    if (dimensions == 2) p.z() = 0.0;
    return p;
  };
  Eigen::Vector3d origin = sensor_origin;
  if (dimensions == 2) origin.z() = 0.0;

  // Shifted sums (about the first point) keep the covariance accurate far from the world origin.
  const Eigen::Vector3d ref = point(0);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero(), noise = Eigen::Matrix3d::Zero();
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector3d p = point(k);
    const Eigen::Vector3d d = p - ref;
    sum += d;
    outer.noalias() += d * d.transpose();
    const Eigen::Vector3d ray = p - origin;
    const double range = ray.norm();
    if (range > 0.0) {
      const Eigen::Vector3d u = ray / range;
      noise.noalias() += u * u.transpose();
    }
  }
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
    // Largest Mahalanobis distance^2 of a cluster point; scale C so that point is on the surface.
    // Each point is pushed away from the centre by its own position uncertainty (3 sigma of range
    // noise plus half a voxel diagonal), so the true surface point behind it is enclosed too.
    const double q = chiSquareQuantile(params.probability, dimensions);
    const double margin = 3.0 * params.range_noise_sigma + 0.5 * params.voxel_size * std::sqrt(double(dimensions));
    auto grown = [margin](auto d) {
      const double length = d.norm();
      return length > 0.0 ? (d * ((length + margin) / length)).eval() : d;
    };
    double worst = 0.0;
    if (dimensions == 2) {
      const Eigen::Matrix2d inverse = covariance.topLeftCorner<2, 2>().inverse();
      for (std::size_t k = 0; k < n; ++k) {
        const Eigen::Vector2d d = grown(Eigen::Vector2d((point(k) - center).head<2>()));
        worst = std::max(worst, d.dot(inverse * d));
      }
    } else {
      const Eigen::Matrix3d inverse = covariance.inverse();
      for (std::size_t k = 0; k < n; ++k) {
        const Eigen::Vector3d d = grown(Eigen::Vector3d(point(k) - center));
        worst = std::max(worst, d.dot(inverse * d));
      }
    }
    if (std::isfinite(worst) && worst > q) covariance *= worst / q;
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

}  // namespace ddsnav::perception
