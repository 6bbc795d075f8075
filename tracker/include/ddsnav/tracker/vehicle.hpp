#pragma once
// The unicycle vehicle model shared by the simulator and the closed-loop tests:
//   x' = v cos(theta), y' = v sin(theta), theta' = omega, z' = vz (3-D only).
// Commands are saturated to the scenario limits (v in [0, v_max], |omega| <= omega_max, |vz| <= vz_max),
// the actuated velocities follow the command within acceleration limits, and an optional coloured
// Gaussian disturbance (wheel slip, wind) is added to the velocities that move the vehicle.

#include "ddsnav/planner/scenario.hpp"

#include <cstdint>
#include <limits>
#include <random>

namespace ddsnav::tracker {

using planner::Vec3;
using planner::VehicleLimits;

struct VehicleState {
  Vec3 position = Vec3::Zero();
  double heading = 0.0;  // rad, CCW from +x, kept in (-pi, pi]
  double v = 0.0;        // actuated forward speed, m/s (without the disturbance)
  double omega = 0.0;    // actuated yaw rate, rad/s
  double vz = 0.0;       // actuated vertical speed, m/s
  double time = 0.0;     // s since reset
};

struct VehicleCommand {
  double v = 0.0;
  double omega = 0.0;
  double vz = 0.0;
};

// Disturbance on the executed velocities: each channel is a first-order Gauss-Markov process with the
// given stationary standard deviation and correlation time, discretised exactly, so the disturbance
// statistics do not depend on the step dt.
struct VehicleNoise {
  double sigma_v = 0.0;            // m/s
  double sigma_omega = 0.0;        // rad/s
  double sigma_vz = 0.0;           // m/s
  double correlation_time = 0.5;   // s
  std::uint64_t seed = 1;

  static VehicleNoise none() { return {}; }
  // The simulator's nominal noise: a few cm/s of speed error and about 1 deg/s of yaw-rate error.
  static VehicleNoise nominal(std::uint64_t seed = 1) { return {0.05, 0.02, 0.03, 0.5, seed}; }
};

struct VehicleConfig {
  VehicleLimits limits;      // v_max, omega_max (vz_max in 3-D) must be > 0
  int dimensions = 2;        // 2: z and vz stay 0
  double max_accel = 2.0;            // m/s^2 on v; infinity disables
  double max_yaw_accel = 3.0;        // rad/s^2 on omega; infinity disables
  double max_vertical_accel = 2.0;   // m/s^2 on vz; infinity disables
  VehicleNoise noise;
};

// Wraps an angle into (-pi, pi].
double wrapAngle(double angle);

class UnicycleVehicle {
 public:
  // Throws std::invalid_argument for non-positive or non-finite limits, a bad dimension, negative noise.
  explicit UnicycleVehicle(const VehicleConfig& config, const VehicleState& initial = {});

  const VehicleConfig& config() const { return config_; }
  const VehicleState& state() const { return state_; }

  // Puts the vehicle at `state` (heading wrapped) and restarts the disturbance from its seed.
  void reset(const VehicleState& state);

  // The command clipped to the vehicle's limits.
  VehicleCommand saturate(const VehicleCommand& command) const;

  // Advances by dt seconds holding `command`. Throws std::invalid_argument for a non-finite command or
  // a dt that is not a positive finite number.
  const VehicleState& step(const VehicleCommand& command, double dt);

 private:
  double disturbance(double& value, double sigma, double dt);

  VehicleConfig config_;
  VehicleState state_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  double noise_v_ = 0.0, noise_omega_ = 0.0, noise_vz_ = 0.0;
};

}  // namespace ddsnav::tracker
