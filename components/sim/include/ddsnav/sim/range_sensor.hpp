#pragma once
// Simulated range sensors (2-D scanner, multi-beam 3-D lidar) ray-cast against a scenario.
//
//   auto sensor = RangeSensor(scenario, RangeSensorConfig::lidar3d(32, 1024));
//   PointCloud cloud = sensor.scan({.position = {10, 5, 1.5}, .yaw = 0.3}, /*stamp=*/0.1);
//
// Every return is the exact first intersection of the beam with a scenario primitive (hills to a
// 1e-6 m bisection tolerance, see ray_primitives.hpp) or with the scenario bounds when they are
// enabled as walls, within [min_range, max_range]; beams that hit nothing give no point.
// Noise and invalid returns are drawn from a generator seeded once by `seed`, so a sensor
// produces the same sequence of clouds for the same seed and poses.

#include <ddsnav/planner/scenario.hpp>

#include <Eigen/Core>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace ddsnav::sim {

struct RangeSensorConfig {
  int rings = 32;                     // vertical beams (1 for a planar scanner)
  int columns = 1024;                 // horizontal beams per ring
  double horizontal_fov_deg = 360.0;  // centred on the sensor's heading
  double vertical_min_deg = -15.0;    // elevation of the lowest ring
  double vertical_max_deg = 15.0;     // elevation of the highest ring
  double min_range = 0.05;            // m; closer returns are dropped
  double max_range = 50.0;            // m; beams that hit nothing within it give no point
  double range_noise_sigma = 0.0;     // m, Gaussian noise added along the beam
  double invalid_fraction = 0.0;      // share of returns replaced by NaN or +inf (half each)
  bool walls = true;                  // the scenario bounds' side faces reflect beams
  bool floor = true;                  // 3-D: the bounds' bottom face (z = min) reflects beams
  bool ceiling = false;               // 3-D: the bounds' top face reflects beams
  std::uint64_t seed = 1;

  // 2-D scanner: one ring in the z = 0 plane.
  static RangeSensorConfig scanner2d(int beams = 720, double max_range = 30.0);
  // Multi-beam lidar with the given vertical field of view.
  static RangeSensorConfig lidar3d(int rings = 32, int columns = 1024, double vertical_min_deg = -15.0,
                                   double vertical_max_deg = 15.0, double max_range = 50.0);

  // Throws std::invalid_argument naming the first bad field.
  void validate() const;
};

struct SensorPose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // world frame; z ignored in 2-D
  double yaw = 0.0;                                    // heading, radians CCW from +x
};

// A cloud in the world frame, as the sensor delivers it (may contain NaN / inf points).
struct PointCloud {
  std::vector<Eigen::Vector3f> points;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // sensor position when the scan was taken
  double stamp = 0.0;                                // seconds
  std::string frame = "world";
};

class RangeSensor {
 public:
  // Throws std::invalid_argument for a bad config, or a planar scenario containing a hill.
  RangeSensor(const planner::Scenario& scenario, const RangeSensorConfig& config);

  PointCloud scan(const SensorPose& pose, double stamp = 0.0);

  // Noise-free ranges of the last scan, row-major (ring * columns + column); +inf = no return.
  // Useful for tests and for ground truth.
  const std::vector<double>& lastRanges() const { return ranges_; }
  // Unit direction of beam (ring, column) in the world frame for the last pose.
  Eigen::Vector3d beamDirection(int ring, int column) const;

  const RangeSensorConfig& config() const { return config_; }
  bool planar() const { return planar_; }

 private:
  struct Primitive {
    planner::Obstacle obstacle;
    Eigen::Vector3d bound_center;
    double bound_radius = 0.0;
    double cos_yaw = 1.0, sin_yaw = 0.0;
  };

  void castPrimitive(const Primitive& primitive, const Eigen::Vector3d& origin);

  planner::Scenario scenario_;
  RangeSensorConfig config_;
  bool planar_ = false;
  std::vector<Primitive> primitives_;
  std::vector<double> ring_elevation_;   // radians
  std::vector<double> column_azimuth_;   // radians, relative to the heading
  std::vector<Eigen::Vector3d> directions_;  // world-frame beam directions for the current yaw
  std::vector<double> ranges_;
  double yaw_ = 0.0;
  std::mt19937_64 rng_;
};

}  // namespace ddsnav::sim
