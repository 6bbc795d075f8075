// ddsnav-sim: the scenario world. Simulates the range sensor at the vehicle's pose (sensors/points) and the
// unicycle vehicle driven by control/cmd_vel (vehicle/state), on simulated time: every step advances the
// simulated clock by 1/state_rate_hz, published on system/clock, and `speed` simulated seconds pass per
// wall second at most: a process on `clock: topic` that falls more than pace_max_lag_s behind (system/progress)
// holds the clock until it catches up (docs/simulator.md, "Pacing").

#include "ddsnav/nodes/convert.hpp"
#include <ddsnav/runtime/component.hpp>

#include <ddsnav/sim/clock_pacer.hpp>
#include <ddsnav/sim/range_sensor.hpp>
#include <ddsnav/sim/sensor_choice.hpp>
#include <ddsnav/tracker/vehicle.hpp>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <string>
#include <vector>

using namespace ddsnav;

namespace {

class SimComponent : public runtime::Component {
 public:
  struct Params {
    std::string scenario;
    double lidar_rate_hz, state_rate_hz, command_timeout_s, speed;
    bool pace;
    sim::PacerParams pacer;
    sim::SensorRequest sensor;
    double range_noise_sigma, invalid_fraction;
    bool walls, noise;
    std::int64_t seed;
    explicit Params(runtime::Parameters& p)
        : scenario(p.require<std::string>("scenario", runtime::ParamSpec{.doc = "scenario file (needs a vehicle block)"})),
          lidar_rate_hz(p.declare<double>("lidar_rate_hz", 10.0, {.above = 0, .max = 100, .unit = "Hz", .doc = "clouds per second"})),
          state_rate_hz(p.declare<double>("state_rate_hz", 50.0, {.above = 0, .max = 1000, .unit = "Hz",
                                                                  .doc = "vehicle steps (and vehicle/state) per second; at least lidar_rate_hz"})),
          command_timeout_s(p.declare<double>("command_timeout_s", 0.5, {.above = 0, .unit = "s", .doc = "stop when no command came for this long (simulated time)"})),
          speed(p.declare<double>("speed", 1.0, {.above = 0, .max = 1000, .doc = "simulated seconds per wall second (system/clock), at most"})),
          pace(p.declare<bool>("pace", true, {.doc = "hold the clock while a process on `clock: topic` lags behind (system/progress)"})),
          pacer{.max_lag_s = p.declare<double>("pace_max_lag_s", 0.3, {.above = 0, .max = 60, .unit = "s",
                                                                       .doc = "simulated time a process may lag behind the clock before it holds it"}),
                .max_hold_s = p.declare<double>("pace_max_hold_s", 10.0, {.above = 0, .max = 3600, .unit = "s",
                                                                          .doc = "wall time one process may hold the clock in a row; then it is not waited for"})},
          sensor(sensorRequest(p)),
          range_noise_sigma(p.declare<double>("range_noise_sigma", 0.02, {.min = 0, .unit = "m", .doc = "range noise of a beam"})),
          invalid_fraction(p.declare<double>("invalid_fraction", 0.01, {.min = 0, .max = 1, .doc = "fraction of beams returned as invalid (NaN)"})),
          // The bounds are a modelling device, not a wall the vehicle could see: off unless asked for.
          walls(p.declare<bool>("walls", false, {.doc = "the scenario's bounds are seen as walls"})),
          noise(p.declare<bool>("noise", true, {.doc = "the vehicle's motion noise (nominal)"})),
          seed(p.declare<std::int64_t>("seed", 1, {.doc = "random seed of the sensor and vehicle noise"})) {}

   private:
    // Every sensor parameter may be left unset: the scenario's rule (sim::chooseSensor, docs/simulator.md)
    // then decides. A planar scanner's 'beams' are a lidar's 'columns'.
    static sim::SensorRequest sensorRequest(runtime::Parameters& p) {
      sim::SensorRequest request;
      const auto kind = p.declare<std::string>("sensor", "auto", {.doc = "sensor kind; auto picks it from the scenario",
                                                                  .choices = {"auto", "scanner", "lidar", "sonar"}});
      try {
        request.kind = sim::parseSensorKind(kind);
      } catch (const std::invalid_argument& e) {
        throw runtime::ParameterError(std::string("parameter 'sensor': ") + e.what());
      }
      request.max_range = p.declareOptional<double>("max_range", {.above = 0, .unit = "m", .doc = "sensor range; default from the scenario's scale"});
      request.fov_deg = p.declareOptional<double>("fov_deg", {.above = 0, .max = 360, .unit = "deg", .doc = "horizontal field of view, centred on the heading"});
      const auto count = [&](const char* name, const char* doc) -> std::optional<int> {
        const auto v = p.declareOptional<std::int64_t>(name, {.min = 1, .max = 1 << 16, .doc = doc});
        return v ? std::optional<int>(static_cast<int>(*v)) : std::nullopt;
      };
      request.beams = count("beams", "horizontal beams of a scan");
      if (const auto columns = count("columns", "3-D lidar: columns (the same as beams)"); columns && !request.beams) request.beams = columns;
      request.rings = count("rings", "3-D lidar: rings");
      request.vertical_min_deg = p.declareOptional<double>("vertical_min_deg", {.min = -90, .max = 90, .unit = "deg", .doc = "3-D lidar: lowest ring"});
      request.vertical_max_deg = p.declareOptional<double>("vertical_max_deg", {.min = -90, .max = 90, .unit = "deg", .doc = "3-D lidar: highest ring"});
      return request;
    }
  };

  explicit SimComponent(runtime::Context& ctx)
      : Component(ctx),
        params_(ctx.params()),
        scenario_(planner::loadScenario(params_.scenario)),
        sensor_(scenario_, sensorChoice().config),
        vehicle_(vehicleConfig(), initialState()),
        clock_(publisher(runtime::topics::clock)),
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
      command_stamp_ = sim_now_;
    });
    if (params_.pace)
      progress_ = subscribe(runtime::topics::progress, [this](const msg::Progress& p) { pacer_.report(p.name(), p.stamp_ns(), std::chrono::steady_clock::now()); });
    steps_per_scan_ = std::max(1, static_cast<int>(std::lround(params_.state_rate_hz / params_.lidar_rate_hz)));
    step_ns_ = static_cast<std::int64_t>(std::llround(1e9 / params_.state_rate_hz));
    // Each step advances simulated time by 1/state_rate_hz; `speed` of them pass per wall period.
    sim_started_ = sim_now_;
    wall_started_ = std::chrono::steady_clock::now();
    last_log_ = wall_started_;
    step_ = every(std::chrono::nanoseconds(static_cast<std::int64_t>(std::llround(1e9 / params_.state_rate_hz / params_.speed))),
                  [this] { step(); });
  }

 private:
  sim::SensorChoice sensorChoice() const {
    try {
      auto choice = sim::chooseSensor(scenario_, params_.sensor);
      auto& config = choice.config;
      config.range_noise_sigma = params_.range_noise_sigma;
      config.invalid_fraction = params_.invalid_fraction;
      config.walls = params_.walls;
      config.seed = static_cast<std::uint64_t>(params_.seed);
      config.validate();
      spdlog::info("sensor: {}", choice.summary);
      return choice;
    } catch (const std::invalid_argument& e) {
      throw runtime::ParameterError("sensor for " + scenario_.source + ": " + e.what());
    }
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
    if (params_.pace && !paced()) return;
    sim_now_ += step_ns_;
    const std::int64_t now = sim_now_;
    tracker::VehicleCommand current;
    // A silent controller must not leave the vehicle driving: stop after the timeout (simulated time).
    if (command_stamp_ != 0 && (now - command_stamp_) * 1e-9 < params_.command_timeout_s) current = command_;
    const auto& state = vehicle_.step(current, 1.0 / params_.state_rate_hz);
    msg::Clock tick;
    tick.stamp_ns(now);
    clock_.publish(tick);
    states_.publish(nodes::toMsg(state, now));
    if (tick_++ % static_cast<std::uint64_t>(steps_per_scan_) == 0) {
      const auto scan_started = std::chrono::steady_clock::now();
      const auto cloud = sensor_.scan({state.position, state.heading}, now * 1e-9);
      scan_ms_.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - scan_started).count());
      clouds_.publish(nodes::toMsg(cloud, now));
    }
    const auto wall_now = std::chrono::steady_clock::now();
    if (wall_now - last_log_ > std::chrono::seconds(10)) {
      // A speed the machine cannot keep up with is not an error: simulated time just runs slower.
      last_log_ = wall_now;
      const double wall = std::chrono::duration<double>(wall_now - wall_started_).count();
      const double simulated = (now - sim_started_) * 1e-9;
      // The scan's ray casting is the step's big cost in 3-D: its time says why a speed is not kept.
      std::sort(scan_ms_.begin(), scan_ms_.end());
      const double scan_median = scan_ms_.empty() ? 0.0 : scan_ms_[scan_ms_.size() / 2];
      const double scan_max = scan_ms_.empty() ? 0.0 : scan_ms_.back();
      scan_ms_.clear();
      spdlog::info("simulated {:.1f} s in {:.1f} s of wall time (speed {:.2f}, asked {:g}); scan median {:.1f} ms, max {:.1f} ms{}",
                   simulated, wall, simulated / wall, params_.speed, scan_median, scan_max, heldSummary());
    }
  }

  // False while a process lags too far behind the clock: the step is skipped and the timer tries again.
  bool paced() {
    const auto wall_now = std::chrono::steady_clock::now();
    const bool advance = pacer_.mayAdvance(sim_now_ + step_ns_, wall_now);
    for (const auto& e : pacer_.takeEvents()) {
      switch (e.kind) {
        case sim::ClockPacer::Event::LongHold:
          spdlog::info("pacing: {} has held the clock for 1 s of wall time ({:.2f} s behind)", e.name, e.lag_s);
          break;
        case sim::ClockPacer::Event::GaveUp:
          spdlog::warn("pacing: {} has held the clock for {:g} s of wall time ({:.2f} s behind); not waiting for it until it catches up",
                       e.name, params_.pacer.max_hold_s, e.lag_s);
          break;
        case sim::ClockPacer::Event::CaughtUp:
          spdlog::info("pacing: {} caught up; waiting for it again", e.name);
          break;
        case sim::ClockPacer::Event::Forgotten:
          spdlog::info("pacing: {} stopped reporting its progress; no longer waiting for it", e.name);
          break;
      }
    }
    return advance;
  }

  // " ; held 1.2 s for mapper, 0.3 s for planner" since the last speed log, or empty.
  std::string heldSummary() {
    std::string out;
    for (const auto& [name, total] : pacer_.heldSeconds()) {
      const double since = total - held_logged_[name];
      held_logged_[name] = total;
      if (since >= 0.05) out += fmt::format("{}{:.1f} s for {}", out.empty() ? "; clock held " : ", ", since, name);
    }
    return out;
  }

  const Params params_;
  const planner::Scenario scenario_;
  sim::RangeSensor sensor_;
  tracker::UnicycleVehicle vehicle_;
  bus::Publisher<msg::Clock> clock_;
  bus::Publisher<msg::PointCloud> clouds_;
  bus::Publisher<msg::VehicleState> states_;
  tracker::VehicleCommand command_;
  // Simulated time, ns since the epoch; it starts at the wall time of the start, so stamps read as dates.
  std::int64_t sim_now_ = runtime::SystemClock().nowNs();
  std::int64_t sim_started_ = 0;
  std::int64_t step_ns_ = 0;
  std::int64_t command_stamp_ = 0;
  std::chrono::steady_clock::time_point wall_started_, last_log_;
  int steps_per_scan_ = 1;
  std::vector<double> scan_ms_;  // wall time of each scan since the last speed log
  std::uint64_t tick_ = 0;
  bus::Subscription commands_;
  sim::ClockPacer pacer_{params_.pacer};
  std::map<std::string, double> held_logged_;
  bus::Subscription progress_;
  runtime::Timer step_;
};

}  // namespace

DDSNAV_COMPONENT(SimComponent, "sim")
