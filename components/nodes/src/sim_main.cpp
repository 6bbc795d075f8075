// ddsnav-sim: the scenario world. Simulates the range sensor at the vehicle's pose (sensors/points) and the
// unicycle vehicle driven by control/cmd_vel (vehicle/state).

#include "ddsnav/nodes/convert.hpp"
#include <ddsnav/runtime/component.hpp>

#include <ddsnav/sim/range_sensor.hpp>
#include <ddsnav/tracker/vehicle.hpp>

#include <spdlog/spdlog.h>

#include <cmath>

using namespace ddsnav;

namespace {

class SimComponent : public runtime::Component {
 public:
  struct Params {
    std::string scenario;
    double lidar_rate_hz, state_rate_hz, command_timeout_s;
    // A planar scanner's 'beams' are the sensor config's 'columns'; the 3-D lidar has rings x columns.
    int beams, rings, columns;
    double vertical_min_deg, vertical_max_deg;
    std::optional<double> max_range;
    double range_noise_sigma, invalid_fraction;
    bool walls, noise;
    std::int64_t seed;
    explicit Params(runtime::Parameters& p)
        : scenario(p.require<std::string>("scenario", runtime::ParamSpec{.doc = "scenario file (needs a vehicle block)"})),
          lidar_rate_hz(p.declare<double>("lidar_rate_hz", 10.0, {.above = 0, .max = 100, .unit = "Hz", .doc = "clouds per second"})),
          state_rate_hz(p.declare<double>("state_rate_hz", 50.0, {.above = 0, .max = 1000, .unit = "Hz",
                                                                  .doc = "vehicle steps (and vehicle/state) per second; at least lidar_rate_hz"})),
          command_timeout_s(p.declare<double>("command_timeout_s", 0.5, {.above = 0, .unit = "s", .doc = "stop when no command came for this long"})),
          beams(count(p, "beams", 720, 1 << 16, "2-D scanner: beams per scan")),
          rings(count(p, "rings", 32, 4096, "3-D lidar: rings")),
          columns(count(p, "columns", 1024, 1 << 16, "3-D lidar: columns")),
          vertical_min_deg(p.declare<double>("vertical_min_deg", -15.0, {.unit = "deg", .doc = "3-D lidar: lowest ring"})),
          vertical_max_deg(p.declare<double>("vertical_max_deg", 15.0, {.unit = "deg", .doc = "3-D lidar: highest ring"})),
          max_range(p.declareOptional<double>("max_range", {.above = 0, .unit = "m", .doc = "sensor range; default 30 m (2-D scanner), 50 m (3-D lidar)"})),
          range_noise_sigma(p.declare<double>("range_noise_sigma", 0.02, {.min = 0, .unit = "m", .doc = "range noise of a beam"})),
          invalid_fraction(p.declare<double>("invalid_fraction", 0.01, {.min = 0, .max = 1, .doc = "fraction of beams returned as invalid (NaN)"})),
          // The bounds are a modelling device, not a wall the vehicle could see: off unless asked for.
          walls(p.declare<bool>("walls", false, {.doc = "the scenario's bounds are seen as walls"})),
          noise(p.declare<bool>("noise", true, {.doc = "the vehicle's motion noise (nominal)"})),
          seed(p.declare<std::int64_t>("seed", 1, {.doc = "random seed of the sensor and vehicle noise"})) {}

   private:
    static int count(runtime::Parameters& p, const char* name, std::int64_t fallback, std::int64_t hi, const char* doc) {
      return static_cast<int>(p.declare<std::int64_t>(name, fallback, {.min = 1, .max = static_cast<double>(hi), .doc = doc}));
    }
  };

  explicit SimComponent(runtime::Context& ctx)
      : Component(ctx),
        params_(ctx.params()),
        scenario_(planner::loadScenario(params_.scenario)),
        sensor_(scenario_, sensorConfig()),
        vehicle_(vehicleConfig(), initialState()),
        clouds_(publisher(runtime::topics::points)),
        states_(publisher(runtime::topics::vehicle_state)) {
    if (params_.state_rate_hz < params_.lidar_rate_hz)
      throw runtime::ParameterError(fmt::format("parameter 'state_rate_hz': expected [lidar_rate_hz, 1000], got {}", params_.state_rate_hz));
    commands_ = subscribe(runtime::topics::cmd_vel, [this](const msg::VelocityCommand& m) {
      if (!std::isfinite(m.v()) || !std::isfinite(m.omega()) || !std::isfinite(m.vz())) {
        spdlog::warn("control/cmd_vel: ignoring a command with non-finite values");
        return;
      }
      command_ = nodes::fromMsg(m);
      command_stamp_ = clock().nowNs();
    });
    steps_per_scan_ = std::max(1, static_cast<int>(std::lround(params_.state_rate_hz / params_.lidar_rate_hz)));
    step_ = every(std::chrono::nanoseconds(static_cast<std::int64_t>(1e9 / params_.state_rate_hz)), [this] { step(); });
  }

 private:
  sim::RangeSensorConfig sensorConfig() const {
    const auto& p = params_;
    sim::RangeSensorConfig config = scenario_.dimensions == 2
                                        ? sim::RangeSensorConfig::scanner2d(p.beams, p.max_range.value_or(30.0))
                                        : sim::RangeSensorConfig::lidar3d(p.rings, p.columns, p.vertical_min_deg, p.vertical_max_deg,
                                                                          p.max_range.value_or(50.0));
    config.range_noise_sigma = p.range_noise_sigma;
    config.invalid_fraction = p.invalid_fraction;
    config.walls = p.walls;
    config.seed = static_cast<std::uint64_t>(p.seed);
    try {
      config.validate();
    } catch (const std::invalid_argument& e) {
      throw runtime::ParameterError(e.what());
    }
    return config;
  }

  tracker::VehicleConfig vehicleConfig() const {
    if (!scenario_.vehicle) throw std::invalid_argument(scenario_.source + ": the simulator needs a 'vehicle' block");
    tracker::VehicleConfig config;
    config.limits = *scenario_.vehicle;
    config.dimensions = scenario_.dimensions;
    if (params_.noise) config.noise = tracker::VehicleNoise::nominal(static_cast<std::uint64_t>(params_.seed));
    return config;
  }

  tracker::VehicleState initialState() const {
    tracker::VehicleState initial;
    initial.position = scenario_.start;
    initial.heading = planner::startHeading(scenario_);  // the planner assumes the same
    return initial;
  }

  void step() {
    tracker::VehicleCommand current;
    // A silent controller must not leave the vehicle driving: stop after the timeout.
    if (command_stamp_ != 0 && (clock().nowNs() - command_stamp_) * 1e-9 < params_.command_timeout_s) current = command_;
    const auto& state = vehicle_.step(current, 1.0 / params_.state_rate_hz);
    const auto now = clock().nowNs();
    states_.publish(nodes::toMsg(state, now));
    if (tick_++ % static_cast<std::uint64_t>(steps_per_scan_) == 0) {
      const auto cloud = sensor_.scan({state.position, state.heading}, now * 1e-9);
      clouds_.publish(nodes::toMsg(cloud, now));
    }
  }

  const Params params_;
  const planner::Scenario scenario_;
  sim::RangeSensor sensor_;
  tracker::UnicycleVehicle vehicle_;
  bus::Publisher<msg::PointCloud> clouds_;
  bus::Publisher<msg::VehicleState> states_;
  tracker::VehicleCommand command_;
  std::int64_t command_stamp_ = 0;
  int steps_per_scan_ = 1;
  std::uint64_t tick_ = 0;
  bus::Subscription commands_;
  runtime::Timer step_;
};

}  // namespace

int main(int argc, char** argv) { return runtime::runComponent<SimComponent>("sim", argc, argv); }
