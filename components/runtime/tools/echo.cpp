// ddsnav-echo: prints the samples of a topic as they arrive, whatever publishes it. The type comes from
// discovery (raw API), so it works across vendors and needs no per-topic code; known types are decoded
// into a one-line summary, others shown as their size.
//
//   ddsnav echo vehicle/state            ddsnav echo --list            ddsnav echo --count 5 system/status
#include <ddsnav/bus/printable.hpp>
#include <ddsnav/msg/messages.hpp>
#include <ddsnav/runtime/component.hpp>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <cstdio>
#include <mutex>
#include <tuple>

using namespace ddsnav;

namespace {

std::string summary(const msg::PointCloud& c) {
  return fmt::format("{} points, {} intensities, origin ({:.2f}, {:.2f}, {:.2f})", c.xyz().size() / 3,
                     c.intensity().size(), c.sensor_origin().x(), c.sensor_origin().y(), c.sensor_origin().z());
}
std::string summary(const msg::VehicleState& s) {
  return fmt::format("pos ({:.2f}, {:.2f}, {:.2f}) heading {:.3f} vel ({:.2f}, {:.2f}) yaw_rate {:.3f}",
                     s.position().x(), s.position().y(), s.position().z(), s.heading(), s.velocity().x(),
                     s.velocity().y(), s.yaw_rate());
}
std::string summary(const msg::VelocityCommand& c) {
  return fmt::format("v {:.3f} omega {:.3f} vz {:.3f}", c.v(), c.omega(), c.vz());
}
std::string summary(const msg::ObstacleArray& a) {
  return fmt::format("{} obstacles{}", a.obstacles().size(), a.planar() ? " (2-D)" : "");
}
std::string summary(const msg::OccupancyMap& m) {
  return fmt::format("octree {} bytes, resolution {} m", m.octree().size(), m.resolution());
}
std::string summary(const msg::PlanRequest& r) {
  return fmt::format("request {} planner {} start ({:.2f}, {:.2f}) goal ({:.2f}, {:.2f}) budget {} s", r.request_id(),
                     r.planner(), r.start().x(), r.start().y(), r.goal().x(), r.goal().y(), r.time_budget_s());
}
std::string summary(const msg::Path& p) {
  return fmt::format("request {} {} {} states, cost {:.3f}, {} iterations{}{}", p.request_id(),
                     p.solved() ? "solved" : "unsolved", p.states().size(), p.cost(), p.statistics().iterations(),
                     p.failure().empty() ? "" : ": ", p.failure());
}
std::string summary(const msg::Trajectory& t) {
  return fmt::format("request {} {} samples", t.request_id(), t.samples().size());
}
std::string summary(const msg::TrackingStatus& s) {
  return fmt::format("cross-track {:.3f} m, progress {:.1f}%{}", s.cross_track_error(), 100 * s.progress(),
                     s.goal_reached() ? ", goal reached" : "");
}
std::string summary(const msg::ComponentStatus& s) {
  static const char* names[] = {"STARTING", "CONFIGURING", "READY", "SHUTTING_DOWN", "FINISHED", "FAILED"};
  const char* state = static_cast<unsigned>(s.state()) < 6 ? names[s.state()] : "?";
  return fmt::format("{} pid {} {}{}{}", s.name(), s.pid(), state, s.detail().empty() ? "" : ": ", s.detail());
}
std::string summary(const msg::Clock& c) { return fmt::format("{} ns", c.stamp_ns()); }

using Summarized = std::tuple<msg::PointCloud, msg::VehicleState, msg::VelocityCommand, msg::ObstacleArray,
                              msg::OccupancyMap, msg::PlanRequest, msg::Path, msg::Trajectory, msg::TrackingStatus,
                              msg::ComponentStatus, msg::Clock>;

// Decodes with the type's own generated code when the type is one of ours.
std::string describe(const bus::RawSample& s) {
  std::string text = fmt::format("{} bytes", s.payload.size());
  std::apply(
      [&](auto... proto) {
        auto one = [&](auto p) {
          using T = decltype(p);
          const msg::TypeSupport& ts = msg::type_support<T>();
          if (ts.name != s.type_name) return;
          T sample;
          // Strings in the sample (names, details, frame ids) are wire bytes: escaped before printing.
          text = ts.deserialize(s.payload.data(), s.payload.size(), &sample) ? bus::printable(summary(sample), 4096)
                                                                              : "undecodable " + text;
        };
        (one(proto), ...);
      },
      Summarized{});
  return text;
}

bus::Qos qosByName(const std::string& name) {
  if (name == "sensor") return bus::Qos::sensorData();
  if (name == "commands") return bus::Qos::commands();
  return bus::Qos::state();
}

}  // namespace

int main(int argc, char** argv) {
  std::string topic, qos_name = "sensor";
  long count = 0;
  double wait_s = 10.0;
  bool list = false;
  return runtime::runComponent(
      "echo", argc, argv,
      [&](runtime::Context& ctx) {
        ctx.ready();
        if (list) {
          // Discovery needs a moment to hear from everyone; report what is known after it.
          ctx.waitForShutdown(std::chrono::milliseconds(static_cast<long>(wait_s * 1000)));
          for (const bus::TopicInfo& t : ctx.bus().discoveredTopics())
            std::printf("%-32s %s%s\n", bus::printable(t.topic).c_str(), bus::printable(t.type_name).c_str(), t.keyed ? " (keyed)" : "");
          return;
        }
        if (topic.empty()) throw std::invalid_argument("give a topic to echo, or --list");
        std::optional<bus::TopicInfo> info;
        auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<long>(wait_s * 1000));
        while (!info && !ctx.shutdownRequested() && std::chrono::steady_clock::now() < deadline)
          info = ctx.bus().waitForTopic(topic, std::chrono::milliseconds(100));
        if (!info) {
          if (ctx.shutdownRequested()) return;
          throw std::runtime_error(fmt::format("no publisher of '{}' seen within {} s", topic, wait_s));
        }
        ctx.log().info("echoing {} ({})", bus::printable(info->topic), bus::printable(info->type_name));
        std::mutex print;
        long printed = 0;
        auto sub = ctx.bus().subscribeRaw(*info, qosByName(qos_name), [&](const bus::RawSample& s) {
          std::lock_guard lock(print);
          if (count > 0 && printed >= count) return;
          std::printf("[%.6f] %s: %s\n", s.source_timestamp_ns * 1e-9, bus::printable(s.topic).c_str(), describe(s).c_str());
          std::fflush(stdout);
          if (count > 0 && ++printed >= count) ctx.requestShutdown();
        });
        ctx.spin();
      },
      [&](CLI::App& app) {
        app.add_option("topic", topic, "topic to print");
        app.add_flag("--list", list, "list the topics with publishers instead");
        app.add_option("--count", count, "exit after this many samples");
        app.add_option("--wait", wait_s, "seconds to wait for the topic to appear (for --list: to listen)")
            ->check(CLI::Range(0.0, 86400.0));
        app.add_option("--qos", qos_name, "sensor (best effort: matches every publisher) | commands | state")
            ->check(CLI::IsMember({"sensor", "commands", "state"}));
      });
}
