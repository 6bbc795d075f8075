// ddsnav-sim: the scenario world. Simulates the range sensor at the vehicle's pose (sensors/points) and the
// unicycle vehicle driven by control/cmd_vel (vehicle/state), on simulated time: every step advances the
// simulated clock by 1/state_rate_hz, published on system/clock, and `speed` simulated seconds pass per
// wall second (components on `clock: topic` follow it; docs/simulator.md).

#include "ddsnav/nodes/convert.hpp"
#include <ddsnav/runtime/component.hpp>

#include <ddsnav/sim/range_sensor.hpp>
#include <ddsnav/sim/sensor_choice.hpp>
#include <ddsnav/tracker/vehicle.hpp>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <optional>

using namespace ddsnav;
using nodes::sleepForWall;

namespace {

// A parameter the user may leave unset (the sensor rule then decides); declared either way.
template <class T>
std::optional<T> optionalParam(runtime::Context& ctx, const char* name) {
  const bool given = ctx.params().has(name);
  const T value = ctx.params().declare<T>(name, T{});
  return given ? std::optional<T>(value) : std::nullopt;
}

// The sensor: chosen from the scenario (sim::chooseSensor, docs/simulator.md) unless the parameters say
// otherwise. Every error names the parameter the user set ('beams' is a lidar's 'columns' too).
sim::SensorChoice sensorChoice(runtime::Context& ctx, const planner::Scenario& scenario) {
  sim::SensorRequest request;
  try {
    request.kind = sim::parseSensorKind(ctx.params().declare<std::string>("sensor", "auto"));
    request.max_range = optionalParam<double>(ctx, "max_range");
    request.fov_deg = optionalParam<double>(ctx, "fov_deg");
    const auto narrow = [](std::optional<std::int64_t> v) -> std::optional<int> {
      if (!v) return std::nullopt;
      return static_cast<int>(std::clamp<std::int64_t>(*v, -1, std::int64_t{1} << 20));  // out of range either way: refused below
    };
    request.beams = narrow(optionalParam<std::int64_t>(ctx, "beams"));
    if (!request.beams) request.beams = narrow(optionalParam<std::int64_t>(ctx, "columns"));
    request.rings = narrow(optionalParam<std::int64_t>(ctx, "rings"));
    request.vertical_min_deg = optionalParam<double>(ctx, "vertical_min_deg");
    request.vertical_max_deg = optionalParam<double>(ctx, "vertical_max_deg");
    auto choice = sim::chooseSensor(scenario, request);
    auto& config = choice.config;
    config.range_noise_sigma = ctx.params().declare<double>("range_noise_sigma", 0.02);
    config.invalid_fraction = ctx.params().declare<double>("invalid_fraction", 0.01);
    // The bounds are a modelling device, not a wall the vehicle could see: off unless asked for.
    config.walls = ctx.params().declare<bool>("walls", false);
    config.seed = static_cast<std::uint64_t>(ctx.params().declare<std::int64_t>("seed", 1));
    config.validate();
    return choice;
  } catch (const std::invalid_argument& e) {
    throw runtime::ParameterError("sensor for " + scenario.source + ": " + e.what());
  }
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

    const double speed = ctx.params().declare<double>("speed", 1.0, "simulated seconds per wall second");
    if (!(speed > 0 && speed <= 1000)) throw runtime::ParameterError(fmt::format("parameter speed: expected (0, 1000], got {}", speed));

    const auto choice = sensorChoice(ctx, scenario);
    spdlog::info("sensor: {}", choice.summary);
    sim::RangeSensor sensor(scenario, choice.config);
    tracker::VehicleConfig vehicle_config;
    vehicle_config.limits = *scenario.vehicle;
    vehicle_config.dimensions = scenario.dimensions;
    if (ctx.params().declare<bool>("noise", true)) vehicle_config.noise = tracker::VehicleNoise::nominal(static_cast<std::uint64_t>(ctx.params().declare<std::int64_t>("seed", 1)));
    tracker::VehicleState initial;
    initial.position = scenario.start;
    initial.heading = planner::startHeading(scenario);  // the planner assumes the same
    tracker::UnicycleVehicle vehicle(vehicle_config, initial);

    auto clock = ctx.bus().publisher<msg::Clock>("system/clock", bus::Qos::sensorData(1));
    auto clouds = ctx.bus().publisher<msg::PointCloud>("sensors/points", bus::Qos::sensorData());
    auto states = ctx.bus().publisher<msg::VehicleState>("vehicle/state", bus::Qos::sensorData());

    std::mutex command_mutex;
    tracker::VehicleCommand command;
    std::int64_t command_stamp = 0;
    // Simulated time, ns since the epoch; it starts at the wall time of the start, so stamps read as dates.
    std::atomic<std::int64_t> sim_now{runtime::SystemClock().nowNs()};
    auto commands = ctx.bus().subscribe<msg::VelocityCommand>(
        "control/cmd_vel", bus::Qos::commands(), [&](const msg::VelocityCommand& m) {
          if (!std::isfinite(m.v()) || !std::isfinite(m.omega()) || !std::isfinite(m.vz())) {
            spdlog::warn("control/cmd_vel: ignoring a command with non-finite values");
            return;
          }
          std::lock_guard lock(command_mutex);
          command = nodes::fromMsg(m);
          command_stamp = sim_now.load();
        });

    ctx.ready();
    const auto step_ns = static_cast<std::int64_t>(std::llround(1e9 / state_rate));
    const auto wall_step = std::chrono::nanoseconds(static_cast<std::int64_t>(std::llround(1e9 / state_rate / speed)));
    const int steps_per_scan = std::max(1, static_cast<int>(std::lround(state_rate / lidar_rate)));
    const double dt = 1.0 / state_rate;
    const auto started = std::chrono::steady_clock::now();
    const std::int64_t sim_started = sim_now.load();
    auto next = started;
    auto last_log = started;
    for (std::uint64_t tick = 0; !ctx.shutdownRequested(); ++tick) {
      tracker::VehicleCommand current;
      const std::int64_t now = sim_now.fetch_add(step_ns) + step_ns;
      {
        std::lock_guard lock(command_mutex);
        // A silent controller must not leave the vehicle driving: stop after the timeout (simulated time).
        if (command_stamp != 0 && (now - command_stamp) * 1e-9 < command_timeout) current = command;
      }
      const auto& state = vehicle.step(current, dt);
      msg::Clock tick_clock;
      tick_clock.stamp_ns(now);
      clock.publish(tick_clock);
      states.publish(nodes::toMsg(state, now));
      if (tick % steps_per_scan == 0) {
        const auto cloud = sensor.scan({state.position, state.heading}, now * 1e-9);
        clouds.publish(nodes::toMsg(cloud, now));
      }
      next += wall_step;
      const auto wall_now = std::chrono::steady_clock::now();
      if (wall_now - last_log > std::chrono::seconds(10)) {
        // A speed the machine cannot keep up with is not an error: simulated time just runs slower.
        last_log = wall_now;
        const double wall = std::chrono::duration<double>(wall_now - started).count();
        spdlog::info("simulated {:.1f} s in {:.1f} s of wall time (speed {:.2f}, asked {:g})", (now - sim_started) * 1e-9, wall,
                     (now - sim_started) * 1e-9 / wall, speed);
      }
      const auto wait = next - wall_now;
      if (wait > std::chrono::nanoseconds::zero() && !sleepForWall(ctx, wait)) break;
      if (wait < -std::chrono::milliseconds(500)) next = std::chrono::steady_clock::now();  // do not try to catch up after a stall
    }
  });
}
