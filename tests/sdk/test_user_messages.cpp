// A message type of a user's own (sdk_test.idl through ddsnav_add_messages) is a first-class bus type:
// typed on both vendors, known by name to the raw API, recorded by the stock `ddsnav record` with its
// OMG IDL schema (decodable by Foxglove's reader from the file alone), replayed by `ddsnav play`, and a
// clear error when replayed by a process that does not know it.
#include <sdk_test_msgs/messages.hpp>

#include <ddsnav/msg/registry.hpp>
#include <ddsnav/record/mcap.hpp>
#include <ddsnav/record/schemas.hpp>
#include <ddsnav/testing/harness.hpp>

#include <gtest/gtest.h>

#include <optional>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>

using namespace ddsnav;
using namespace std::chrono_literals;
using sdk_test::msg::Reading;
namespace fs = std::filesystem;

namespace {

Reading reading(int i) {
  Reading r;
  r.header().stamp_ns(1'000'000'000LL * (i + 1));
  r.header().frame_id("map");
  r.value(0.5 * i);
  r.samples({i, -i, 7});
  r.label("reading " + std::to_string(i));
  return r;
}

TEST(UserMessages, RegisteredByNameWithASelfContainedSchema) {
  const msg::TypeSupport* type = msg::find_type_support("sdk_test::msg::Reading");
  ASSERT_NE(type, nullptr);
  EXPECT_EQ(type, &msg::type_support<Reading>());
  const auto schema = record::idlSchemaFor("sdk_test::msg::Reading");
  ASSERT_TRUE(schema);
  // The user's struct and the stock one it uses, without the #include that a reader could not follow.
  EXPECT_NE(schema->find("struct Reading"), std::string::npos) << *schema;
  EXPECT_NE(schema->find("struct Header"), std::string::npos) << *schema;
  EXPECT_EQ(schema->find("#include"), std::string::npos) << *schema;
}

TEST(UserMessages, TypedRoundTripAcrossVendors) {
  ddsnav::testing::DomainLease domain;
  bus::Participant fast({.vendor = bus::Vendor::FastDDS, .domain_id = domain.id(), .name = "user-fast"});
  bus::Participant cyclone({.vendor = bus::Vendor::CycloneDDS, .domain_id = domain.id(), .name = "user-cyclone"});
  auto inbox = cyclone.inbox<Reading>("sdk/readings", bus::Qos::commands());
  auto pub = fast.publisher<Reading>("sdk/readings", bus::Qos::commands());
  ASSERT_TRUE(pub.waitForSubscribers(1, 10s));  // matched both ways: the one sample reaches the reader
  pub.publish(reading(3));
  const std::optional<Reading> got = inbox.wait(10s);
  ASSERT_TRUE(got);
  EXPECT_EQ(*got, reading(3));
}

// ddsnav record and play are the stock executables: they learn the type from DDSNAV_MESSAGE_LIBRARIES.
class UserMessagesRecording : public ::testing::Test {
 protected:
  void SetUp() override { ::setenv(msg::kMessageLibrariesVariable, SDK_TEST_MSGS_LIBRARY, 1); }
  void TearDown() override { ::unsetenv(msg::kMessageLibrariesVariable); }

  // Records five readings with `ddsnav record` (Cyclone) from a Fast DDS publisher; returns the file.
  std::string recordReadings(harness::Harness& h) {
    const std::string file = h.logDir() + "/readings.mcap";
    h.start({.name = "rec", .command = "ddsnav-record", .args = {"--topics", "sdk/readings", "-o", file}, .dds = "cyclonedds"});
    auto pub = h.bus().publisher<Reading>("sdk/readings", bus::Qos::commands());
    EXPECT_TRUE(pub.waitForSubscribers(1, 20s)) << h.log("rec");
    for (int i = 0; i < 5; ++i) pub.publish(reading(i));
    std::this_thread::sleep_for(500ms);  // reliable delivery of the last ones
    h.stop("rec");
    return file;
  }
};

TEST_F(UserMessagesRecording, RecordedWithItsSchemaDecodedByFoxglove) {
  harness::Harness h({.record = false});
  const std::string file = recordReadings(h);
  {
    record::McapReader reader(file);
    bool found = false;
    for (const auto& [id, channel] : reader.channels()) {
      if (channel.topic != "sdk/readings") continue;
      found = true;
      const auto& schema = reader.schemas().at(channel.schema_id);
      EXPECT_EQ(schema.name, "sdk_test::msg::Reading");
      EXPECT_EQ(schema.encoding, "omgidl");
    }
    ASSERT_TRUE(found) << h.log("rec");
  }

  // Foxglove's OMG IDL reader, given only the file.
  const std::string command = std::string(NODE_BIN) + " " + DECODE_SCRIPT + " " + file + " sdk/readings 2>&1";
  std::string decoded;
  FILE* pipe = ::popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  char buffer[4096];
  while (std::fgets(buffer, sizeof buffer, pipe)) decoded += buffer;
  ASSERT_EQ(::pclose(pipe), 0) << decoded;
  EXPECT_NE(decoded.find(R"("label":"reading 4")"), std::string::npos) << decoded;
  EXPECT_NE(decoded.find(R"("samples":[4,-4,7])"), std::string::npos) << decoded;
  EXPECT_NE(decoded.find(R"("frame_id":"map")"), std::string::npos) << decoded;
  EXPECT_NE(decoded.find(R"("value":2)"), std::string::npos) << decoded;
}

TEST_F(UserMessagesRecording, RecordedUserTypeReplaysOnTheBus) {
  harness::Harness h({.record = false});
  const std::string file = recordReadings(h);
  // ddsnav play puts the same samples back on the bus (Fast DDS this time).
  auto inbox = h.bus().inbox<Reading>("sdk/readings", bus::Qos::commands());
  // Waits for the inbox to match before the first sample: published unmatched, a sample is gone.
  h.replay(file, {.clock = false, .dds = "fastdds", .args = {"--wait-subscribers", "10", "--settle", "2"}});
  for (int i = 0; i < 5; ++i) {
    const auto got = inbox.wait(20s);
    ASSERT_TRUE(got) << "reading " << i << " not replayed; play:\n" << h.log("play");
    EXPECT_EQ(*got, reading(i));
  }
  const auto status = h.waitExit("play", 20s);
  ASSERT_TRUE(status);
  EXPECT_EQ(WEXITSTATUS(*status), 0) << h.log("play");
}

TEST_F(UserMessagesRecording, ReplayWithoutTheTypeIsAnErrorNamingIt) {
  harness::Harness h({.record = false});
  const std::string file = recordReadings(h);
  ::unsetenv(msg::kMessageLibrariesVariable);  // this ddsnav play knows the stock types only
  h.replay(file, {.clock = false});
  const auto status = h.waitExit("play", 20s);
  ASSERT_TRUE(status);
  EXPECT_NE(WEXITSTATUS(*status), 0);
  const std::string log = h.log("play");
  EXPECT_NE(log.find("sdk_test::msg::Reading"), std::string::npos) << log;
  EXPECT_NE(log.find(msg::kMessageLibrariesVariable), std::string::npos) << log;
}

TEST(UserMessages, AnUnloadableLibraryIsAnErrorNamingTheFile) {
  harness::Harness h({.record = false});
  const std::string file = h.logDir() + "/stock.mcap";
  {
    record::McapWriter w(file);
    const auto schema = w.addSchema("ddsnav::msg::VelocityCommand", "omgidl", *record::idlSchemaFor("ddsnav::msg::VelocityCommand"));
    const auto ch = w.addChannel(schema, "control/cmd_vel", "cdr", {{"dds_type", "ddsnav::msg::VelocityCommand"}, {"keyed", "false"}});
    w.write(ch, 1, 1, msg::serializeToBytes(msg::VelocityCommand()));
    w.close();
  }
  ::setenv(msg::kMessageLibrariesVariable, "/no/such/libmy_msgs.so", 1);
  h.replay(file, {.clock = false});
  const auto status = h.waitExit("play", 20s);
  ::unsetenv(msg::kMessageLibrariesVariable);
  ASSERT_TRUE(status) << h.log("play");
  EXPECT_NE(WEXITSTATUS(*status), 0);
  EXPECT_NE(h.log("play").find("/no/such/libmy_msgs.so"), std::string::npos) << h.log("play");
}

}  // namespace
