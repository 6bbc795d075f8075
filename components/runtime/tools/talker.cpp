// ddsnav-talker: a first pipeline on the bus. Publishes a vehicle driving a circle on vehicle/state
// (and, as every component, its heartbeat on system/status). Pair it with `ddsnav echo vehicle/state`.
#include <ddsnav/msg/messages.hpp>
#include <ddsnav/runtime/component.hpp>

#include <CLI/CLI.hpp>

#include <cmath>

using namespace ddsnav;

int main(int argc, char** argv) {
  long count = 0;
  return runtime::runComponent(
      "talker", argc, argv,
      [&](runtime::Context& ctx) {
        const double rate_hz = ctx.params().declare<double>("rate_hz", 10.0, "samples per second");
        const double radius = ctx.params().declare<double>("radius", 5.0, "circle radius, m");
        const double speed = ctx.params().declare<double>("speed", 1.0, "forward speed, m/s");
        if (rate_hz <= 0 || radius <= 0) throw runtime::ParameterError("rate_hz and radius must be positive");
        auto pub = ctx.bus().publisher<msg::VehicleState>("vehicle/state", bus::Qos::sensorData());
        ctx.ready();
        const double omega = speed / radius;
        const std::int64_t t0 = ctx.clock().nowNs();
        long sent = 0;
        ctx.spin(std::chrono::milliseconds(static_cast<long>(1000.0 / rate_hz)), [&] {
          const std::int64_t now = ctx.clock().nowNs();
          const double t = static_cast<double>(now - t0) * 1e-9;
          const double a = omega * t;
          msg::VehicleState s;
          s.header().stamp_ns(now);
          s.header().frame_id("map");
          s.position().x(radius * std::cos(a));
          s.position().y(radius * std::sin(a));
          s.heading(std::remainder(a + M_PI / 2, 2 * M_PI));
          s.velocity().x(-speed * std::sin(a));
          s.velocity().y(speed * std::cos(a));
          s.yaw_rate(omega);
          pub.publish(s);
          if (count > 0 && ++sent >= count) ctx.requestShutdown();
        });
      },
      [&](CLI::App& app) { app.add_option("--count", count, "stop after this many samples (0: run until a signal)"); });
}
