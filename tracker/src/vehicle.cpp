#include "ddsnav/tracker/vehicle.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace ddsnav::tracker {

double wrapAngle(double angle) {
  if (!std::isfinite(angle)) return angle;
  double a = std::remainder(angle, 2.0 * std::numbers::pi);  // [-pi, pi]
  if (a <= -std::numbers::pi) a += 2.0 * std::numbers::pi;
  return a;
}

namespace {

void requirePositive(double value, const char* name) {
  if (!(value > 0.0) || std::isnan(value))
    throw std::invalid_argument(std::string("vehicle: ") + name + " must be > 0, got " + std::to_string(value));
}

// Moves `current` toward `target` by at most rate * dt.
double rateLimit(double current, double target, double rate, double dt) {
  if (!std::isfinite(rate)) return target;
  const double step = rate * dt;
  return std::clamp(target, current - step, current + step);
}

}  // namespace

UnicycleVehicle::UnicycleVehicle(const VehicleConfig& config, const VehicleState& initial) : config_(config) {
  if (config_.dimensions != 2 && config_.dimensions != 3)
    throw std::invalid_argument("vehicle: dimensions must be 2 or 3, got " + std::to_string(config_.dimensions));
  requirePositive(config_.limits.v_max, "v_max");
  requirePositive(config_.limits.omega_max, "omega_max");
  if (config_.dimensions == 3) requirePositive(config_.limits.vz_max, "vz_max");
  requirePositive(config_.max_accel, "max_accel");
  requirePositive(config_.max_yaw_accel, "max_yaw_accel");
  requirePositive(config_.max_vertical_accel, "max_vertical_accel");
  const auto& n = config_.noise;
  for (double s : {n.sigma_v, n.sigma_omega, n.sigma_vz})
    if (!(s >= 0.0) || !std::isfinite(s)) throw std::invalid_argument("vehicle: noise sigmas must be finite and >= 0");
  requirePositive(n.correlation_time, "noise.correlation_time");
  if (!std::isfinite(n.correlation_time)) throw std::invalid_argument("vehicle: noise.correlation_time must be finite");
  reset(initial);
}

void UnicycleVehicle::reset(const VehicleState& state) {
  if (!state.position.allFinite() || !std::isfinite(state.heading) || !std::isfinite(state.v) ||
      !std::isfinite(state.omega) || !std::isfinite(state.vz) || !std::isfinite(state.time))
    throw std::invalid_argument("vehicle: initial state has non-finite values");
  state_ = state;
  state_.heading = wrapAngle(state.heading);
  if (config_.dimensions == 2) {
    state_.vz = 0.0;
  }
  rng_.seed(config_.noise.seed);
  noise_v_ = noise_omega_ = noise_vz_ = 0.0;
}

VehicleCommand UnicycleVehicle::saturate(const VehicleCommand& c) const {
  const auto& l = config_.limits;
  VehicleCommand out;
  out.v = std::clamp(c.v, 0.0, l.v_max);
  out.omega = std::clamp(c.omega, -l.omega_max, l.omega_max);
  out.vz = config_.dimensions == 3 ? std::clamp(c.vz, -l.vz_max, l.vz_max) : 0.0;
  return out;
}

double UnicycleVehicle::disturbance(double& value, double sigma, double dt) {
  if (sigma <= 0.0) return 0.0;
  // Exact discretisation of an Ornstein-Uhlenbeck process with stationary std sigma.
  const double phi = std::exp(-dt / config_.noise.correlation_time);
  value = phi * value + sigma * std::sqrt(1.0 - phi * phi) * normal_(rng_);
  return value;
}

const VehicleState& UnicycleVehicle::step(const VehicleCommand& command, double dt) {
  if (!(dt > 0.0) || !std::isfinite(dt))
    throw std::invalid_argument("vehicle: step dt must be a positive finite number, got " + std::to_string(dt));
  if (!std::isfinite(command.v) || !std::isfinite(command.omega) || !std::isfinite(command.vz))
    throw std::invalid_argument("vehicle: command has non-finite values");

  const VehicleCommand target = saturate(command);
  state_.v = rateLimit(state_.v, target.v, config_.max_accel, dt);
  state_.omega = rateLimit(state_.omega, target.omega, config_.max_yaw_accel, dt);
  state_.vz = config_.dimensions == 3 ? rateLimit(state_.vz, target.vz, config_.max_vertical_accel, dt) : 0.0;

  const auto& n = config_.noise;
  // The disturbance acts on motion that is happening: no forward creep while turning in place or stopped,
  // no turning while stopped. The processes keep running so their statistics do not depend on the path.
  const double dv = disturbance(noise_v_, n.sigma_v, dt);
  const double domega = disturbance(noise_omega_, n.sigma_omega, dt);
  const double dvz = config_.dimensions == 3 ? disturbance(noise_vz_, n.sigma_vz, dt) : 0.0;
  const bool moving = state_.v > 1e-6 || std::abs(state_.omega) > 1e-6 || std::abs(state_.vz) > 1e-6;
  double v = state_.v, omega = state_.omega, vz = state_.vz;
  if (state_.v > 1e-6) v = std::max(0.0, v + dv);
  if (moving) omega += domega;
  if (moving && config_.dimensions == 3) vz += dvz;

  // Exact integration of the unicycle for constant (v, omega) over dt: a straight line or a circular arc.
  const double theta0 = state_.heading;
  const double dtheta = omega * dt;
  if (std::abs(dtheta) < 1e-9) {
    state_.position.x() += v * dt * std::cos(theta0 + 0.5 * dtheta);
    state_.position.y() += v * dt * std::sin(theta0 + 0.5 * dtheta);
  } else {
    const double r = v / omega;
    state_.position.x() += r * (std::sin(theta0 + dtheta) - std::sin(theta0));
    state_.position.y() -= r * (std::cos(theta0 + dtheta) - std::cos(theta0));
  }
  state_.position.z() += vz * dt;
  state_.heading = wrapAngle(theta0 + dtheta);
  state_.time += dt;
  return state_;
}

}  // namespace ddsnav::tracker
