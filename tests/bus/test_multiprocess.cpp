// Typed round trips of every message type between two processes (this test and bus_test_peer, which
// echoes), for every vendor pair, including an 8 MB point cloud.
#include "child_process.hpp"
#include "samples.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <thread>

#include <atomic>

#ifndef BUS_TEST_PEER
#error "BUS_TEST_PEER must name the bus_test_peer executable"
#endif

namespace ddsnav::test {
namespace {

using bus::Vendor;

void echoEveryType(Vendor local, Vendor remote, int domain_offset) {
  ChildProcess peer({BUS_TEST_PEER, "--dds", std::string(bus::vendorName(remote)), "--domain",
                     std::to_string(testDomain(domain_offset))});
  ASSERT_EQ(peer.readLine(kWait), std::optional<std::string>("READY"));
  bus::Participant p(options(local, domain_offset, "echo-client"));
  forEachMessageType([&](auto proto) {
    using T = decltype(proto);
    SCOPED_TRACE(shortName<T>());
    auto pub = p.publisher<T>("in/" + shortName<T>(), bus::Qos::state(2));
    auto inbox = p.inbox<T>("out/" + shortName<T>(), bus::Qos::state(2));
    const T sample = makeSample<T>(5);
    pub.publish(sample);  // transient local: delivered once the peer matches, no sleep needed
    std::optional<T> got = inbox.wait(kWait);
    ASSERT_TRUE(got.has_value()) << "no echo";
    EXPECT_EQ(*got, sample);
  });
  auto pub = p.publisher<msg::PointCloud>("in/BigCloud", bus::Qos::state(2));
  auto inbox = p.inbox<msg::PointCloud>("out/BigCloud", bus::Qos::state(2));
  const msg::PointCloud cloud = makeCloud(6, 8 * 1024 * 1024 / 12);
  pub.publish(cloud);
  std::optional<msg::PointCloud> got = inbox.wait(kWait);
  ASSERT_TRUE(got.has_value()) << "no 8 MB echo";
  EXPECT_TRUE(*got == cloud);
  EXPECT_EQ(peer.stop(std::chrono::seconds(5)), 0) << "peer did not exit cleanly on SIGTERM";
}

// A reader that cannot keep up with a reliable keep-last writer misses samples the writer overwrote
// before they were acknowledged (RTPS sends a GAP for them, and no DDS status counts them). The bus counts
// them from the writer's sequence numbers, so received + lost is exactly what was written. Fast DDS readers
// (of either vendor's writer); Cyclone DDS 0.10 exposes no sequence numbers to count with (docs/record.md).
// (Cyclone's writer blocks instead of overwriting while the unacknowledged samples fit its writer history
// cache, so with it the test checks only that nothing is counted twice or made up.)
// kBurst exceeds what the reader's shared-memory port queues (8192 messages, fastdds_backend.cpp) so a Fast DDS
// writer must give samples up; with fewer the queue holds the whole burst and the slow reader gets every one.
void everyMissedSampleCounted(Vendor writer, int domain_offset, bool expect_losses) {
  const int kBurst = writer == Vendor::FastDDS ? 12000 : 3000;
  ChildProcess peer({BUS_TEST_PEER, "--dds", std::string(bus::vendorName(writer)), "--domain",
                     std::to_string(testDomain(domain_offset)), "--burst", std::to_string(kBurst)});
  ASSERT_EQ(peer.readLine(kWait), std::optional<std::string>("READY"));
  bus::Participant p(options(Vendor::FastDDS, domain_offset, "slow-reader"));
  std::atomic<int> received{0};
  bus::Subscription slow = p.subscribe<msg::VehicleState>("burst/state", bus::Qos::state(1), [&](const msg::VehicleState&) {
    if (received.fetch_add(1) > 0) std::this_thread::sleep_for(std::chrono::microseconds(200));
  });
  ASSERT_EQ(peer.readLine(kWait * 3), std::optional<std::string>("DONE"));
  const auto until = std::chrono::steady_clock::now() + kWait;
  while (received.load() + slow.lostSamples() < kBurst + 1 && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // nothing more may arrive or be counted
  EXPECT_EQ(received.load() + slow.lostSamples(), static_cast<std::uint64_t>(kBurst + 1))
      << received.load() << " received, " << slow.lostSamples() << " counted lost";
  if (expect_losses) {
    EXPECT_GT(slow.lostSamples(), 0u) << "the reader kept up: nothing was lost, so nothing was tested";
  }
  EXPECT_EQ(peer.stop(std::chrono::seconds(5)), 0);
}

TEST(BusLostSamples, FastReaderCountsWhatAFastWriterOverwrote) { everyMissedSampleCounted(Vendor::FastDDS, 25, true); }
TEST(BusLostSamples, FastReaderAccountsForEverySampleOfACycloneWriter) {
  everyMissedSampleCounted(Vendor::CycloneDDS, 26, false);
}

TEST(BusTwoProcesses, FastToFast) { echoEveryType(Vendor::FastDDS, Vendor::FastDDS, 20); }
TEST(BusTwoProcesses, CycloneToCyclone) { echoEveryType(Vendor::CycloneDDS, Vendor::CycloneDDS, 21); }
TEST(BusTwoProcesses, FastToCyclone) { echoEveryType(Vendor::FastDDS, Vendor::CycloneDDS, 22); }
TEST(BusTwoProcesses, CycloneToFast) { echoEveryType(Vendor::CycloneDDS, Vendor::FastDDS, 23); }

}  // namespace
}  // namespace ddsnav::test

#include <dirent.h>
#include <fcntl.h>
#include <sys/file.h>

#include <set>

namespace ddsnav::test {
namespace {

std::set<std::string> shmSegments() {
  std::set<std::string> names;
  DIR* dir = opendir("/dev/shm");
  if (dir == nullptr) return names;
  while (dirent* e = readdir(dir)) {
    std::string n = e->d_name;
    if (n.starts_with("fastrtps_") && !n.starts_with("fastrtps_port") && !n.ends_with("_el")) names.insert(n);
  }
  closedir(dir);
  return names;
}

bool lockedByLiveProcess(const std::string& segment) {
  int fd = open(("/dev/shm/" + segment + "_el").c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  bool locked = flock(fd, LOCK_EX | LOCK_NB) != 0;
  close(fd);
  return locked;
}

// A Fast DDS process killed with SIGKILL leaves its shared-memory segment behind; the next bus
// participant's start removes it (and leaves segments of live processes alone).
TEST(BusSharedMemory, StaleSegmentsOfKilledProcessRemoved) {
  setenv("DDSNAV_FAST_SHM", "1", 1);  // the peer inherits it: segments even where a run turned them off (tsan)
  const std::set<std::string> before = shmSegments();
  std::set<std::string> dead;
  {
    ChildProcess peer({BUS_TEST_PEER, "--dds", "fastdds", "--domain", std::to_string(testDomain(24))});
    ASSERT_EQ(peer.readLine(kWait), std::optional<std::string>("READY"));
    std::set<std::string> during = shmSegments();
    kill(peer.pid(), SIGKILL);
    peer.stop(std::chrono::seconds(5));  // reaps it
    for (const std::string& s : during)
      if (!before.count(s) && !lockedByLiveProcess(s)) dead.insert(s);  // others' live segments excluded
  }
  ASSERT_FALSE(dead.empty()) << "the killed peer left no segment to clean; the test proves nothing";
  // The cleaning is the first Fast DDS participant's of a process: a fresh process, so that what ran before in
  // this one (another test of the same executable) does not matter.
  ChildProcess cleaner({BUS_TEST_PEER, "--dds", "fastdds", "--domain", std::to_string(testDomain(24))});
  ASSERT_EQ(cleaner.readLine(kWait), std::optional<std::string>("READY"));
  const std::set<std::string> after = shmSegments();
  for (const std::string& s : dead) EXPECT_EQ(after.count(s), 0u) << "stale segment left: " << s;
}

}  // namespace
}  // namespace ddsnav::test
