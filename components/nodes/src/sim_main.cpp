// ddsnav-sim: the scenario world. Simulates the range sensor at the vehicle's pose (sensors/points) and the
// unicycle vehicle driven by control/cmd_vel (vehicle/state).

#include "ddsnav/nodes/convert.hpp"
#include <ddsnav/runtime/component.hpp>

#include <ddsnav/sim/range_sensor.hpp>
#include <ddsnav/tracker/vehicle.hpp>

#include <spdlog/spdlog.h>

#include <atomic>
#include <cmath>
#include <mutex>

using namespace ddsnav;
using nodes::sleepFor;

namespace {

// An integer parameter within [lo, hi], checked here so the error names the parameter the user set (a
// planar scanner's 'beams' are the sensor config's 'columns').
int countParam(runtime::Context& ctx, const char* name, std::int64_t fallback, std::int64_t lo, std::int64_t hi) {
  const auto value = ctx.params().declare<std::int64_t>(name, fallback);
  if (value < lo || value > hi) throw runtime::ParameterError(fmt::format("parameter {}: expected [{}, {}], got {}", name, lo, hi, value));
  return static_cast<int>(value);
}

sim::RangeSensorConfig sensorConfig(runtime::Context& ctx, const planner::Scenario& scenario) {
  sim::RangeSensorConfig config =
      scenario.dimensions == 2
          ? sim::RangeSensorConfig::scanner2d(countParam(ctx, "beams", 720, 1, 1 << 16), ctx.params().declare<double>("max_range", 30.0))
          : sim::RangeSensorConfig::lidar3d(countParam(ctx, "rings", 32, 1, 4096), countParam(ctx, "columns", 1024, 1, 1 << 16),
                                            ctx.params().declare<double>("vertical_min_deg", -15.0), ctx.params().declare<double>("vertical_max_deg", 15.0),
                                            ctx.params().declare<double>("max_range", 50.0));
  config.range_noise_sigma = ctx.params().declare<double>("range_noise_sigma", 0.02);
  config.invalid_fraction = ctx.params().declare<double>("invalid_fraction", 0.01);
  // The bounds are a modelling device, not a wall the vehicle could see: off unless asked for.
  config.walls = ctx.params().declare<bool>("walls", false);
  config.seed = static_cast<std::uint64_t>(ctx.params().declare<std::int64_t>("seed", 1));
  try {
    config.validate();
  } catch (const std::invalid_argument& e) {
    throw runtime::ParameterError(e.what());
  }
  return config;
}

}  // namespace

int main(int argc, char** argv) {
  return runtime::runComponent("sim", argc, argv, [](runtime::Context& ctx) {
    const auto scenario = planner::loadScenario(ctx.params().require<std::string>("scenario"));
    if (!scenario.vehicle) throw std::invalid_argument(scenario.source + ": the simulator needs a 'vehicle' block");
    const double lidar_rate = ctx.params().declare<double>("lidar_rate_hz", 10.0);
    const double state_rate = ctx.params().declare<double>("state_rate_hz", 50.0);
    const double command_timeout = ctx.params().declare<double>("command_timeout_s", 0.5);
    if (!(command_timeout > 0) || !std::isfinite(command_timeout))
      throw runtime::ParameterError(fmt::format("parameter command_timeout_s: expected a positive finite number of seconds, got {}", command_timeout));
    if (!(lidar_rate > 0 && lidar_rate <= 100)) throw runtime::ParameterError("parameter lidar_rate_hz: expected (0, 100]");
    if (!(state_rate >= lidar_rate && state_rate <= 1000))
      throw runtime::ParameterError("parameter state_rate_hz: expected [lidar_rate_hz, 1000]");

    sim::RangeSensor sensor(scenario, sensorConfig(ctx, scenario));
    tracker::VehicleConfig vehicle_config;
    vehicle_config.limits = *scenario.vehicle;
    vehicle_config.dimensions = scenario.dimensions;
    if (ctx.params().declare<bool>("noise", true)) vehicle_config.noise = tracker::VehicleNoise::nominal(static_cast<std::uint64_t>(ctx.params().declare<std::int64_t>("seed", 1)));
    tracker::VehicleState initial;
    initial.position = scenario.start;
    initial.heading = planner::startHeading(scenario);  // the planner assumes the same
    tracker::UnicycleVehicle vehicle(vehicle_config, initial);

    auto clouds = ctx.bus().publisher<msg::PointCloud>("sensors/points", bus::Qos::sensorData());
    auto states = ctx.bus().publisher<msg::VehicleState>("vehicle/state", bus::Qos::sensorData());

    std::mutex command_mutex;
    tracker::VehicleCommand command;
    std::int64_t command_stamp = 0;
    auto commands = ctx.bus().subscribe<msg::VelocityCommand>(
        "control/cmd_vel", bus::Qos::commands(), [&](const msg::VelocityCommand& m) {
          if (!std::isfinite(m.v()) || !std::isfinite(m.omega()) || !std::isfinite(m.vz())) {
            spdlog::warn("control/cmd_vel: ignoring a command with non-finite values");
            return;
          }
          std::lock_guard lock(command_mutex);
          command = nodes::fromMsg(m);
          command_stamp = ctx.clock().nowNs();
        });

    ctx.ready();
    const auto step = std::chrono::nanoseconds(static_cast<std::int64_t>(1e9 / state_rate));
    const int steps_per_scan = std::max(1, static_cast<int>(std::lround(state_rate / lidar_rate)));
    const double dt = 1.0 / state_rate;
    auto next = std::chrono::steady_clock::now();
    for (std::uint64_t tick = 0; !ctx.shutdownRequested(); ++tick) {
      tracker::VehicleCommand current;
      {
        std::lock_guard lock(command_mutex);
        // A silent controller must not leave the vehicle driving: stop after the timeout.
        if (command_stamp != 0 && (ctx.clock().nowNs() - command_stamp) * 1e-9 < command_timeout) current = command;
      }
      const auto& state = vehicle.step(current, dt);
      const auto now = ctx.clock().nowNs();
      states.publish(nodes::toMsg(state, now));
      if (tick % steps_per_scan == 0) {
        const auto cloud = sensor.scan({state.position, state.heading}, now * 1e-9);
        clouds.publish(nodes::toMsg(cloud, now));
      }
      next += step;
      const auto wait = next - std::chrono::steady_clock::now();
      if (wait > std::chrono::nanoseconds::zero() && !sleepFor(ctx, wait)) break;
      if (wait < -std::chrono::milliseconds(500)) next = std::chrono::steady_clock::now();  // do not try to catch up after a stall
    }
  });
}
