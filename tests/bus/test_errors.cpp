// Clear errors: unknown vendor, domain out of range, type mismatch, bad raw bytes, unknown raw types.
#include "samples.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <set>
#include <stdexcept>
#include <string>

namespace ddsnav::test {
namespace {

using bus::Vendor;

// Runs f, expecting a BusError whose message contains every one of the given fragments.
template <class F>
void expectBusError(F&& f, std::initializer_list<std::string_view> fragments) {
  try {
    f();
    ADD_FAILURE() << "no BusError thrown";
  } catch (const bus::BusError& e) {
    for (std::string_view frag : fragments) EXPECT_NE(std::string(e.what()).find(frag), std::string::npos) << e.what();
  }
}

TEST(BusErrors, UnknownVendorNamesTheChoices) {
  expectBusError([] { bus::parseVendor("opendds"); }, {"opendds", "fastdds", "cyclonedds"});
  EXPECT_EQ(bus::parseVendor("cyclonedds"), Vendor::CycloneDDS);
  EXPECT_EQ(bus::parseVendor("fastdds"), Vendor::FastDDS);
  setenv("DDSNAV_DDS", "rti", 1);
  expectBusError([] { bus::vendorFromEnvironment(); }, {"DDSNAV_DDS", "rti"});
  setenv("DDSNAV_DDS", "cyclonedds", 1);
  EXPECT_EQ(bus::vendorFromEnvironment(), Vendor::CycloneDDS);
  unsetenv("DDSNAV_DDS");
  EXPECT_EQ(bus::vendorFromEnvironment(Vendor::FastDDS), Vendor::FastDDS);
}

TEST(BusErrors, DomainFromEnvironmentIsStrict) {
  unsetenv("DDSNAV_DOMAIN");
  EXPECT_EQ(bus::domainFromEnvironment(7), 7);
  setenv("DDSNAV_DOMAIN", "", 1);
  EXPECT_EQ(bus::domainFromEnvironment(7), 7);
  setenv("DDSNAV_DOMAIN", "42", 1);
  EXPECT_EQ(bus::domainFromEnvironment(7), 42);
  setenv("DDSNAV_DOMAIN", "0", 1);
  EXPECT_EQ(bus::domainFromEnvironment(7), 0);
  setenv("DDSNAV_DOMAIN", std::to_string(bus::kMaxDomainId).c_str(), 1);
  EXPECT_EQ(bus::domainFromEnvironment(7), bus::kMaxDomainId);
  // std::atoi would have read these as 0, 5, 5, 0, ...: each must be refused, naming the variable and value.
  for (const char* bad : {"abc", "5x", "5 ", " 5", "5.0", "-1", "233", "99999999999", "0x10"}) {
    setenv("DDSNAV_DOMAIN", bad, 1);
    try {
      bus::domainFromEnvironment(7);
      ADD_FAILURE() << "DDSNAV_DOMAIN='" << bad << "' was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("DDSNAV_DOMAIN"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(std::string("'") + bad + "'"), std::string::npos) << e.what();
    }
  }
  unsetenv("DDSNAV_DOMAIN");
}

// Fast DDS shared-memory segments this process has mapped (/proc/self/maps names their /dev/shm files).
std::size_t mappedFastSegments() {
  std::ifstream maps("/proc/self/maps");
  std::set<std::string> files;
  for (std::string line; std::getline(maps, line);)
    if (auto at = line.find("/dev/shm/fastrtps_"); at != std::string::npos) files.insert(line.substr(at));
  return files.size();
}

TEST(BusErrors, FastSharedMemoryFollowsTheEnvironmentUnlessTheOptionSaysSo) {
  unsetenv("DDSNAV_FAST_SHM");
  EXPECT_TRUE(bus::fastSharedMemoryFromEnvironment());
  for (const char* on : {"1", "true", "on", ""}) {
    setenv("DDSNAV_FAST_SHM", on, 1);
    EXPECT_TRUE(bus::fastSharedMemoryFromEnvironment()) << on;
  }
  for (const char* off : {"0", "false", "off"}) {
    setenv("DDSNAV_FAST_SHM", off, 1);
    EXPECT_FALSE(bus::fastSharedMemoryFromEnvironment()) << off;
  }
  setenv("DDSNAV_FAST_SHM", "no", 1);
  expectBusError([] { bus::fastSharedMemoryFromEnvironment(); }, {"DDSNAV_FAST_SHM", "'no'"});
  bus::ParticipantOptions o;
  o.domain_id = testDomain(25);
  o.name = "shm-env";
  expectBusError([&] { bus::Participant p(o); }, {"DDSNAV_FAST_SHM"});

  // Off: the participant maps no segment; the option set to true overrides the environment.
  setenv("DDSNAV_FAST_SHM", "0", 1);
  const std::size_t before = mappedFastSegments();
  {
    bus::Participant without(o);
    EXPECT_EQ(mappedFastSegments(), before) << "DDSNAV_FAST_SHM=0 left the shared-memory transport on";
  }
  o.fast_shared_memory = true;
  {
    bus::Participant with(o);
    EXPECT_GT(mappedFastSegments(), before) << "fast_shared_memory = true did not override DDSNAV_FAST_SHM=0";
  }
  unsetenv("DDSNAV_FAST_SHM");
}

TEST(BusErrors, DomainOutOfRange) {
  for (Vendor v : {Vendor::FastDDS, Vendor::CycloneDDS}) {
    for (int domain : {-1, bus::kMaxDomainId + 1, 100000}) {
      bus::ParticipantOptions o;
      o.vendor = v;
      o.domain_id = domain;
      expectBusError([&] { bus::Participant p(o); }, {std::to_string(domain), "out of range"});
    }
  }
}

// A network that cannot be used is refused before a participant exists, never replaced by loopback.
TEST(BusErrors, NetworkThatCannotBeUsedIsNamed) {
  for (Vendor v : {Vendor::FastDDS, Vendor::CycloneDDS}) {
    bus::ParticipantOptions o;
    o.vendor = v;
    o.domain_id = 0;
    o.network = bus::NetworkOptions{"ddsnav-nosuch0", {"127.0.0.1"}, false};
    // The error lists the interfaces that do exist (loopback is always there).
    expectBusError([&] { bus::Participant p(o); }, {"'ddsnav-nosuch0' does not exist", "lo"});
    o.network = bus::NetworkOptions{"lo", {"no-such-host.invalid"}, false};
    expectBusError([&] { bus::Participant p(o); }, {"peer 'no-such-host.invalid'"});
    o.network = bus::NetworkOptions{"", {"127.0.0.1"}, false};
    expectBusError([&] { bus::Participant p(o); }, {"without an interface"});
  }
}

TEST(BusErrors, TopicTypeMismatchInOneParticipant) {
  for (Vendor v : {Vendor::FastDDS, Vendor::CycloneDDS}) {
    bus::Participant p(options(v, 15, "mismatch"));
    auto pub = p.publisher<msg::Clock>("shared/topic", bus::Qos::commands());
    expectBusError([&] { p.subscribe<msg::VehicleState>("shared/topic", bus::Qos::commands(),
                                                        [](const msg::VehicleState&) {}); },
                   {"shared/topic", "ddsnav::msg::Clock", "ddsnav::msg::VehicleState"});
    expectBusError([&] { p.rawPublisher({"shared/topic", "ddsnav::msg::Path", false}, bus::Qos::commands()); },
                   {"shared/topic", "ddsnav::msg::Path"});
    // The same type again is fine.
    EXPECT_NO_THROW(p.subscribe<msg::Clock>("shared/topic", bus::Qos::commands(), [](const msg::Clock&) {}));
  }
}

TEST(BusErrors, BadQosDepth) {
  for (Vendor v : {Vendor::FastDDS, Vendor::CycloneDDS}) {
    bus::Participant p(options(v, 15, "depth"));
    expectBusError([&] { p.publisher<msg::Clock>("clock/zero", bus::Qos::state(0)); }, {"depth", "0"});
  }
}

TEST(BusErrors, RawBytesChecked) {
  bus::Participant cyclone(options(Vendor::CycloneDDS, 15, "raw-errors"));
  auto pub = cyclone.rawPublisher({"raw/cloud", "ddsnav::msg::PointCloud", false}, bus::Qos::commands());
  expectBusError([&] { pub.publish(std::vector<std::uint8_t>{0, 1}); }, {"2 bytes", "encapsulation"});
  // A cloud header claiming 1e6 floats that are not there: Cyclone's type check refuses it.
  std::vector<std::uint8_t> truncated = {0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 4, 0, 0, 0, 'm', 'a', 'p', 0};
  expectBusError([&] { pub.publish(truncated); }, {"raw/cloud", "not a valid ddsnav::msg::PointCloud"});
}

TEST(BusErrors, RawUnknownTypes) {
  bus::Participant cyclone(options(Vendor::CycloneDDS, 15, "unknown-c"));
  expectBusError([&] { cyclone.subscribeRaw({"x/y", "other::Thing", false}, bus::Qos::commands(),
                                            [](const bus::RawSample&) {}); },
                 {"other::Thing", "unknown to this build"});
  bus::Participant fast(options(Vendor::FastDDS, 15, "unknown-f"));
  expectBusError([&] { fast.rawPublisher({"x/z", "other::Keyed", true}, bus::Qos::commands()); },
                 {"other::Keyed", "key"});
  // Keyed-ness that contradicts the known type.
  expectBusError([&] { fast.rawPublisher({"x/w", "ddsnav::msg::ComponentStatus", false}, bus::Qos::commands()); },
                 {"ComponentStatus", "keyed"});
}

}  // namespace
}  // namespace ddsnav::test
