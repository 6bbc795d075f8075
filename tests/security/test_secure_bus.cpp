// DDS Security on each vendor, with real component processes: secured participants talk; one without
// credentials neither reads a sample nor gets one accepted; an identity cannot publish a topic its
// permissions lack; bad credentials stop a participant before it starts; the secured demo reaches the goal.
// Domains 131..136, and leased ones for the newer tests (the 250..259 range given to this suite is above the RTPS maximum of 232).
#include <ddsnav/msg/messages.hpp>
#include <ddsnav/security/security.hpp>
#include <ddsnav/testing/harness.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <thread>

using namespace ddsnav;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

namespace {

constexpr int kIntruderDomain = 131;     // + vendor index
constexpr int kPermissionsDomain = 133;  // + vendor index
constexpr int kDemoDomain = 135;         // + vendor index

int vendorIndex(bus::Vendor v) { return v == bus::Vendor::FastDDS ? 0 : 1; }

// A fresh credentials directory for one test, removed afterwards; `test-harness` is the harness's own
// observer, allowed to read everything.
struct Credentials {
  fs::path dir = fs::temp_directory_path() /
                 ("ddsnav_sec_" + std::to_string(::getpid()) + "_" +
                  ::testing::UnitTest::GetInstance()->current_test_info()->name());
  Credentials() {
    fs::remove_all(dir);
    security::initDirectory(dir.string(), {.grants = security::stockGrants()});
    security::addIdentity(dir.string(), {"test-harness", {"system/status", "ddsnav_internal/*"}, {"*"}},
                          security::Validity::fromNow(1));
  }
  ~Credentials() { fs::remove_all(dir); }
};

// Every participant this process creates (the harness's too) and every process it starts is secured.
struct SecuredEnvironment {
  explicit SecuredEnvironment(const fs::path& dir) { ::setenv("DDSNAV_SECURITY", dir.c_str(), 1); }
  ~SecuredEnvironment() { ::unsetenv("DDSNAV_SECURITY"); }
};

std::string busError(const std::function<void()>& call) {
  try {
    call();
  } catch (const bus::BusError& e) {
    return e.what();
  }
  return "";
}

class SecureBus : public ::testing::TestWithParam<bus::Vendor> {};

std::string vendorLabel(const ::testing::TestParamInfo<bus::Vendor>& info) {
  return info.param == bus::Vendor::FastDDS ? "FastDDS" : "CycloneDDS";
}

}  // namespace

// Lines the echo component printed for samples of `topic`.
int printedSamples(const std::string& log, const std::string& topic) {
  int n = 0;
  for (std::size_t at = log.find("] " + topic + ":"); at != std::string::npos; at = log.find("] " + topic + ":", at + 1)) ++n;
  return n;
}

TEST_P(SecureBus, AParticipantWithoutCredentialsNeitherReadsNorInjects) {
  const bus::Vendor vendor = GetParam();
  const std::string dds(bus::vendorName(vendor));
  Credentials keys;
  SecuredEnvironment secured(keys.dir);
  harness::Harness h(kIntruderDomain + vendorIndex(vendor), vendor);
  h.startReady({.name = "talker", .command = "ddsnav-talker", .params = {{"rate_hz", "20"}}, .dds = dds}, 30s);
  h.startReady({.name = "echo", .command = "ddsnav-echo", .args = {"vehicle/state", "--qos", "sensor"}, .dds = dds}, 30s);

  // The secured observer (a participant like any component) counts the talker's samples and any that
  // come from the intruder, which drives a circle 100 times larger.
  std::atomic<int> secured_samples{0}, injected_accepted{0};
  bus::Subscription watch = h.bus().subscribe<msg::VehicleState>(
      "vehicle/state", bus::Qos::sensorData(), [&](const msg::VehicleState& s) {
        (std::hypot(s.position().x(), s.position().y()) > 100 ? injected_accepted : secured_samples)++;
      });

  // Without credentials (--security "" overrides the inherited DDSNAV_SECURITY): an echo listens for 4 s
  // (well past the ~1 s secured participants need to match here)...
  h.start({.name = "eavesdropper", .command = "ddsnav-echo",
           .args = {"vehicle/state", "--qos", "sensor", "--security", "", "--wait", "4", "--count", "1"}, .dds = dds});
  const auto eavesdrop_end = std::chrono::steady_clock::now() + 20s;
  while (h.running("eavesdropper") && std::chrono::steady_clock::now() < eavesdrop_end) std::this_thread::sleep_for(100ms);
  ASSERT_FALSE(h.running("eavesdropper")) << h.log("eavesdropper");
  EXPECT_EQ(printedSamples(h.log("eavesdropper"), "vehicle/state"), 0) << h.log("eavesdropper");
  EXPECT_NE(h.log("eavesdropper").find("no publisher of 'vehicle/state'"), std::string::npos) << h.log("eavesdropper");

  // ...then a talker without credentials publishes for 4 s.
  const int accepted_before = secured_samples.load();
  h.start({.name = "intruder", .command = "ddsnav-talker", .args = {"--security", "", "--name", "intruder"},
           .params = {{"rate_hz", "20"}, {"radius", "777"}}, .dds = dds});
  std::this_thread::sleep_for(4s);
  EXPECT_TRUE(h.running("intruder")) << h.log("intruder");
  h.stop("intruder");

  EXPECT_EQ(injected_accepted.load(), 0) << "a secured participant accepted samples from one without credentials";
  EXPECT_GT(secured_samples.load() - accepted_before, 20) << "the secured observer saw too few talker samples";
  EXPECT_GT(printedSamples(h.log("echo"), "vehicle/state"), 40) << h.log("echo");
  // The echo prints "pos (x, y, z)": none of its samples is on the intruder's circle.
  const std::string echo_log = h.log("echo");
  const std::regex position(R"(pos \((-?[0-9.]+), (-?[0-9.]+))");
  int far = 0;
  for (auto it = std::sregex_iterator(echo_log.begin(), echo_log.end(), position); it != std::sregex_iterator(); ++it)
    if (std::hypot(std::stod((*it)[1]), std::stod((*it)[2])) > 100) ++far;
  EXPECT_EQ(far, 0) << "the echo component printed injected samples";
}

TEST_P(SecureBus, AnIdentityCannotPublishOrReadATopicItsPermissionsLack) {
  const bus::Vendor vendor = GetParam();
  Credentials keys;
  bus::Participant perception({.vendor = vendor,
                               .domain_id = kPermissionsDomain + vendorIndex(vendor),
                               .name = "perception",
                               .security_dir = keys.dir.string()});
  EXPECT_NO_THROW(perception.publisher<msg::ObstacleArray>("perception/obstacles", bus::Qos::state()));
  EXPECT_NO_THROW(perception.subscribe<msg::PointCloud>("sensors/points", bus::Qos::sensorData(), [](const msg::PointCloud&) {}));
  const std::string publish_error =
      busError([&] { perception.publisher<msg::VelocityCommand>("control/cmd_vel", bus::Qos::commands()); });
  EXPECT_NE(publish_error.find("control/cmd_vel"), std::string::npos) << publish_error;
  EXPECT_NE(publish_error.find("permissions"), std::string::npos) << publish_error;
  const std::string read_error = busError([&] {
    perception.subscribe<msg::Path>("planning/path", bus::Qos::state(), [](const msg::Path&) {});
  });
  EXPECT_NE(read_error.find("planning/path"), std::string::npos) << read_error;
}

static std::size_t threadCount() {
  return static_cast<std::size_t>(std::distance(fs::directory_iterator("/proc/self/task"), fs::directory_iterator()));
}

// Cyclone keeps a domain's threads (receive, timed events, the security plugins' handshakes and
// encryption) while the domain exists; had it outlived the last participant, they would still run when
// main returns and exit handlers free what they use (OpenSSL's cipher tables: the secured launcher's
// SIGSEGV at exit). After the last participant every thread it brought is gone.
TEST(SecureCyclone, NoThreadOutlivesTheLastParticipant) {
  Credentials keys;
  ddsnav::testing::DomainLease domain;
  const std::size_t before = threadCount();
  for (int round = 0; round < 2; ++round) {  // and the domain can be made again afterwards
    {
      bus::Participant sim({.vendor = bus::Vendor::CycloneDDS, .domain_id = domain.id(), .name = "sim",
                            .security_dir = keys.dir.string()});
      auto states = sim.publisher<msg::VehicleState>("vehicle/state", bus::Qos::sensorData());
      states.publish(msg::VehicleState{});
      EXPECT_GT(threadCount(), before);
    }
    EXPECT_EQ(threadCount(), before) << "round " << round;
  }
}

TEST_P(SecureBus, BadCredentialsStopTheParticipantBeforeItStarts) {
  const bus::Vendor vendor = GetParam();
  Credentials keys;
  const auto now = security::Clock::now();
  security::addIdentity(keys.dir.string(), {"expired", {"*"}, {"*"}}, {now - 48h, now - 24h});
  const bus::ParticipantOptions expired{.vendor = vendor, .domain_id = kPermissionsDomain + vendorIndex(vendor),
                                        .name = "expired", .security_dir = keys.dir.string()};
  std::string error = busError([&] { bus::Participant p(expired); });
  EXPECT_NE(error.find("identities/expired/cert"), std::string::npos) << error;  // cert.pem, cert-cyclonedds.pem
  EXPECT_NE(error.find("has expired"), std::string::npos) << error;
  EXPECT_NE(error.find("participant 'expired' not created"), std::string::npos) << error;
  // An identity that is not in the directory: no fall-back to an unsecured participant.
  error = busError([&] { bus::Participant p({.vendor = vendor, .domain_id = 0, .name = "nobody", .security_dir = keys.dir.string()}); });
  EXPECT_NE(error.find("no identity 'nobody'"), std::string::npos) << error;
  // A domain the governance does not cover (Cyclone refuses ids above 230 in it): named, before any vendor call.
  error = busError([&] { bus::Participant p({.vendor = vendor, .domain_id = 231, .name = "sim", .security_dir = keys.dir.string()}); });
  EXPECT_NE(error.find("domain 231 is outside the domains 0..230"), std::string::npos) << error;
  // The environment variable is just as binding.
  {
    SecuredEnvironment secured(keys.dir / "missing");
    error = busError([&] { bus::Participant p({.vendor = vendor, .domain_id = 0, .name = "sim"}); });
    EXPECT_NE(error.find("missing' does not exist"), std::string::npos) << error;
  }
  // A governance document replaced by one signed with another CA.
  const fs::path other = keys.dir.string() + "_other";
  security::initDirectory(other.string(), {.grants = {}});
  fs::copy_file(other / "governance.p7s", keys.dir / "governance.p7s", fs::copy_options::overwrite_existing);
  error = busError([&] { bus::Participant p({.vendor = vendor, .domain_id = 0, .name = "sim", .security_dir = keys.dir.string()}); });
  EXPECT_NE(error.find("governance.p7s': signature does not verify"), std::string::npos) << error;
  fs::remove_all(other);
}

// The secured demo on `domain`, every process on `vendor`: reaches the goal, with obstacles seen, and
// every process (the launcher too) exits 0.
static void runSecuredDemo(int domain, bus::Vendor vendor) {
  Credentials keys;
  harness::Harness h(domain, vendor);
  const fs::path out = keys.dir.string() + "_out";
  fs::remove_all(out);
  h.start({.name = "launcher",
           .command = "ddsnav-launch",
           .args = {std::string(DDSNAV_SOURCE_DIR) + "/tests/security/secure_demo.yaml", "--domain", std::to_string(h.domain()),
                    "--dds", std::string(bus::vendorName(vendor)), "--set", "security=" + keys.dir.string(), "--set",
                    "out=" + out.string()}});
  const auto deadline = std::chrono::steady_clock::now() + 200s;
  while (h.running("launcher") && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(200ms);
  ASSERT_FALSE(h.running("launcher")) << "the secured demo did not end within 200 s\n" << h.log("launcher");
  // On Cyclone the launcher once died with SIGSEGV after a clean teardown (its domain's threads outlived
  // main and met OpenSSL's exit cleanup); the exit status is what would show it again.
  const int status = h.stop("launcher");
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status << "\n" << h.log("launcher");
  std::ifstream summary_file(out / "summary.json");
  ASSERT_TRUE(summary_file.good()) << "no summary.json in " << out << "\n" << h.log("launcher");
  const auto summary = nlohmann::json::parse(summary_file, nullptr, false);
  ASSERT_TRUE(summary.is_object());
  EXPECT_TRUE(summary.value("goal_reached", false)) << summary.dump(2);
  EXPECT_GT(summary.value("obstacles", 0), 0) << summary.dump(2);
  fs::remove_all(out);
}

TEST_P(SecureBus, TheSecuredDemoReachesTheGoal) {
  runSecuredDemo(kDemoDomain + vendorIndex(GetParam()), GetParam());
}

INSTANTIATE_TEST_SUITE_P(Vendors, SecureBus, ::testing::Values(bus::Vendor::FastDDS, bus::Vendor::CycloneDDS), vendorLabel);
