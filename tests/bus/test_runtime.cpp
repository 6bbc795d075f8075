// Component runtime: parameters (file + overrides, type checks, clear errors), the topic clock, and a
// real component process (ddsnav-talker): READY heartbeat on system/status, clean exit on SIGTERM.
#include "child_process.hpp"
#include "samples.hpp"
#include "test_support.hpp"

#include <ddsnav/runtime/clock.hpp>
#include <ddsnav/runtime/parameters.hpp>

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#ifndef DDSNAV_TALKER
#error "DDSNAV_TALKER must name the ddsnav-talker executable"
#endif
#ifndef DDSNAV_ECHO
#error "DDSNAV_ECHO must name the ddsnav-echo executable"
#endif

namespace ddsnav::test {
namespace {

using runtime::ParameterError;
using runtime::Parameters;

std::string writeTemp(const std::string& text) {
  char path[] = "/tmp/ddsnav_params_XXXXXX.yaml";
  int fd = mkstemps(path, 5);
  std::ofstream(path) << text;
  close(fd);
  return path;
}

template <class F>
std::string errorOf(F&& f) {
  try {
    f();
  } catch (const ParameterError& e) {
    return e.what();
  }
  return "";
}

TEST(RuntimeParameters, FileNestedKeysAndOverrides) {
  std::string file = writeTemp("resolution: 0.1\noctree:\n  max_range: 20\n  frame: map\nenabled: true\nlimits: [1, 2, 3]\n");
  Parameters p = Parameters::load(file, {"octree.max_range=35", "name=mapper-2"});
  EXPECT_DOUBLE_EQ(p.declare<double>("resolution", 1.0), 0.1);
  EXPECT_EQ(p.declare<int>("octree.max_range", 0), 35);  // the override wins
  EXPECT_EQ(p.declare<std::string>("octree.frame", ""), "map");
  EXPECT_TRUE(p.declare<bool>("enabled", false));
  EXPECT_EQ(p.declare<std::vector<int>>("limits", {}), (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(p.declare<std::string>("name", ""), "mapper-2");
  EXPECT_EQ(p.declare<double>("absent", 4.5), 4.5);
  EXPECT_NO_THROW(p.rejectUndeclared());
  EXPECT_EQ(p.sources().at("octree.max_range"), "--param");
  EXPECT_EQ(p.sources().at("resolution"), file);
  std::remove(file.c_str());
}

TEST(RuntimeParameters, TypeErrorsNameTheParameterAndSource) {
  std::string file = writeTemp("rate_hz: fast\ncount: 2.5\n");
  Parameters p = Parameters::load(file, {"ratio=.inf", "flag=maybe"});
  std::string e = errorOf([&] { p.declare<double>("rate_hz", 1.0, "samples per second"); });
  EXPECT_NE(e.find("'rate_hz'"), std::string::npos) << e;
  EXPECT_NE(e.find(file), std::string::npos) << e;
  EXPECT_NE(e.find("expected a number"), std::string::npos) << e;
  EXPECT_NE(errorOf([&] { p.declare<int>("count", 1); }).find("expected an integer"), std::string::npos);
  EXPECT_NE(errorOf([&] { p.declare<double>("ratio", 1.0); }).find("finite"), std::string::npos);
  EXPECT_NE(errorOf([&] { p.declare<bool>("flag", false); }).find("'flag' (from --param)"), std::string::npos);
  std::remove(file.c_str());
}

TEST(RuntimeParameters, MissingUnknownAndMalformed) {
  Parameters p = Parameters::load("", {"resoltion=0.2"});
  EXPECT_NE(errorOf([&] { p.require<double>("resolution", "leaf size"); }).find("missing required parameter 'resolution'"),
            std::string::npos);
  std::string e = errorOf([&] { p.rejectUndeclared(); });
  EXPECT_NE(e.find("resoltion"), std::string::npos) << e;
  EXPECT_NE(e.find("takes: resolution"), std::string::npos) << e;
  EXPECT_NE(errorOf([] { Parameters::load("", {"novalue"}); }).find("expected key=value"), std::string::npos);
  EXPECT_NE(errorOf([] { Parameters::load("/nonexistent/x.yaml", {}); }).find("cannot read config file"),
            std::string::npos);
  std::string bad = writeTemp("a: [1, 2\n");
  EXPECT_NE(errorOf([&] { Parameters::load(bad, {}); }).find(bad), std::string::npos);
  std::remove(bad.c_str());
}

// A list or map as a key escaped as a bare yaml-cpp exception naming neither file nor key (the launch
// fuzz target found the same in launch files; tests/fuzz/corpus/parameters/regress-complex-key replays it).
TEST(RuntimeParameters, ComplexKeyNamesTheFileAndLine) {
  std::string file = writeTemp("rate_hz: 1\noctree:\n  ? [a, b]\n  : 3\n");
  const std::string e = errorOf([&] { Parameters::load(file, {}); });
  EXPECT_NE(e.find(file + "' line 3"), std::string::npos) << e;
  EXPECT_NE(e.find("under 'octree' is a list"), std::string::npos) << e;
  std::remove(file.c_str());
}

TEST(RuntimeClock, TopicClockFollowsPublishedTime) {
  for (bus::Vendor v : {bus::Vendor::FastDDS, bus::Vendor::CycloneDDS}) {
    SCOPED_TRACE(vendorTag(v));
    bus::Participant p(options(v, 30, "clock"));
    runtime::TopicClock clock(p);
    EXPECT_FALSE(clock.valid());
    auto pub = p.publisher<msg::Clock>("system/clock", bus::Qos::sensorData(1));
    ASSERT_TRUE(pub.waitForSubscribers(1, kWait));
    msg::Clock c;
    c.stamp_ns(5'000'000'000LL);
    pub.publish(c);
    auto deadline = std::chrono::steady_clock::now() + kWait;
    while (clock.nowNs() != c.stamp_ns() && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    EXPECT_EQ(clock.nowNs(), c.stamp_ns());
    EXPECT_TRUE(clock.valid());
    c.stamp_ns(4'000'000'000LL);  // older: ignored, time never runs backwards
    pub.publish(c);
    c.stamp_ns(6'000'000'000LL);
    pub.publish(c);
    deadline = std::chrono::steady_clock::now() + kWait;
    while (clock.nowNs() != c.stamp_ns() && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    EXPECT_EQ(clock.nowNs(), 6'000'000'000LL);
  }
}

// A component process reports READY on system/status, then exits 0 on SIGTERM within its bound.
void componentLifecycle(bus::Vendor component_vendor, bus::Vendor observer_vendor, int domain_offset) {
  bus::Participant observer(options(observer_vendor, domain_offset, "status-observer"));
  auto status = observer.inbox<msg::ComponentStatus>("system/status", bus::Qos::state(1));
  ChildProcess talker({DDSNAV_TALKER, "--dds", std::string(bus::vendorName(component_vendor)), "--domain",
                       std::to_string(testDomain(domain_offset)), "--name", "talker-under-test", "--param",
                       "heartbeat_period_s=0.2", "--log-level", "warn"});
  bool ready = false;
  auto deadline = std::chrono::steady_clock::now() + kWait;
  while (!ready && std::chrono::steady_clock::now() < deadline) {
    std::optional<msg::ComponentStatus> s = status.wait(kWait);
    ASSERT_TRUE(s.has_value()) << "no status from the component";
    EXPECT_EQ(s->name(), "talker-under-test");
    EXPECT_EQ(s->pid(), talker.pid());
    EXPECT_EQ(s->ready(), s->state() == msg::LIFECYCLE_READY);
    ready = s->ready();
  }
  ASSERT_TRUE(ready) << "component never said READY";
  EXPECT_EQ(talker.stop(std::chrono::seconds(6)), 0) << "no clean exit on SIGTERM";
}

TEST(RuntimeComponent, FastComponentLifecycle) {
  componentLifecycle(bus::Vendor::FastDDS, bus::Vendor::CycloneDDS, 31);
}
TEST(RuntimeComponent, CycloneComponentLifecycle) {
  componentLifecycle(bus::Vendor::CycloneDDS, bus::Vendor::FastDDS, 32);
}

// Issue 13 row 6: a component that got SIGTERM twice (the launcher's, then PR_SET_PDEATHSIG's or a
// watchdog's) exited 3 without a clean shutdown. Repeated SIGTERMs are now one clean shutdown.
TEST(RuntimeComponent, RepeatedSigtermIsStillOneCleanShutdown) {
  bus::Participant observer(options(bus::Vendor::CycloneDDS, 36, "status-observer"));
  auto status = observer.inbox<msg::ComponentStatus>("system/status", bus::Qos::state(1));
  ChildProcess talker({DDSNAV_TALKER, "--dds", "fastdds", "--domain", std::to_string(testDomain(36)), "--name",
                       "talker-twice", "--log-level", "warn"});
  bool ready = false;
  const auto deadline = std::chrono::steady_clock::now() + kWait;
  while (!ready && std::chrono::steady_clock::now() < deadline) {
    std::optional<msg::ComponentStatus> s = status.wait(kWait);
    ASSERT_TRUE(s.has_value()) << "no status from the component";
    ready = s->ready() && s->pid() == talker.pid();
  }
  ASSERT_TRUE(ready);
  ASSERT_EQ(::kill(talker.pid(), SIGTERM), 0);
  ASSERT_EQ(::kill(talker.pid(), SIGTERM), 0);
  EXPECT_EQ(talker.stop(std::chrono::seconds(8)), 0) << "a third SIGTERM (from stop) too: still exit 0, not 3";
}

// Bad command lines exit with status 2 and say why on stderr (not checked here: just the status).
TEST(RuntimeComponent, UsageErrorsExitWithTwo) {
  for (std::vector<std::string> args : {std::vector<std::string>{"--dds", "opendds"},
                                        std::vector<std::string>{"--domain", "300"},
                                        std::vector<std::string>{"--param", "rate_hz=abc"},
                                        std::vector<std::string>{"--param", "no_such_param=1"},
                                        // durations bounded where they enter (a 1e300 s bound overflowed)
                                        std::vector<std::string>{"--param", "shutdown_timeout_s=1e300"},
                                        std::vector<std::string>{"--param", "heartbeat_period_s=inf"}}) {
    args.insert(args.begin(), DDSNAV_TALKER);
    args.insert(args.end(), {"--log-level", "off", "--domain", std::to_string(testDomain(33))});
    if (args[1] == "--domain") args.resize(args.size() - 2);
    ChildProcess p(args);
    std::optional<std::string> line = p.readLine(kWait);  // EOF when it exits
    EXPECT_FALSE(line.has_value());
    EXPECT_EQ(p.stop(std::chrono::seconds(5)), 2) << args[1] << " " << args[2];
  }
}

}  // namespace
}  // namespace ddsnav::test

namespace ddsnav::test {
namespace {

// The first pipeline on the bus: ddsnav-talker on Cyclone, ddsnav-echo on Fast DDS finds the topic by
// discovery and prints decoded samples.
TEST(RuntimeTools, EchoPrintsTalkerAcrossVendors) {
  const std::string domain = std::to_string(testDomain(34));
  ChildProcess talker({DDSNAV_TALKER, "--dds", "cyclonedds", "--domain", domain, "--param", "rate_hz=50",
                       "--log-level", "warn"});
  ChildProcess echo({DDSNAV_ECHO, "vehicle/state", "--dds", "fastdds", "--domain", domain, "--count", "3",
                     "--log-level", "warn"});
  for (int i = 0; i < 3; ++i) {
    std::optional<std::string> line = echo.readLine(kWait);
    ASSERT_TRUE(line.has_value()) << "echo printed " << i << " lines";
    EXPECT_NE(line->find("vehicle/state: pos ("), std::string::npos) << *line;
    EXPECT_NE(line->find("yaw_rate 0.200"), std::string::npos) << *line;  // speed 1 / radius 5
  }
  EXPECT_FALSE(echo.readLine(kWait).has_value()) << "echo did not stop after --count samples";
  EXPECT_EQ(echo.stop(std::chrono::seconds(5)), 0);
}

}  // namespace
}  // namespace ddsnav::test
