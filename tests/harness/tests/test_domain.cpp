// The domain id allocator: distinct ids while leases are held, across processes, never a reserved id.
#include <ddsnav/testing/domain.hpp>

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <list>
#include <set>

using namespace ddsnav::testing;
namespace fs = std::filesystem;

namespace {

// Each test gets its own lock folder and pool, so it never takes ids from the real tests running beside it.
class DomainAllocator : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = fs::temp_directory_path() / ("ddsnav_domain_test_" + std::to_string(::getpid()));
    fs::create_directories(folder_);
    ::setenv("DDSNAV_TEST_DOMAIN_LOCKS", folder_.c_str(), 1);
  }
  void TearDown() override {
    ::unsetenv("DDSNAV_TEST_DOMAIN_LOCKS");
    ::unsetenv("DDSNAV_TEST_DOMAINS");
    std::error_code ignored;
    fs::remove_all(folder_, ignored);
  }
  fs::path folder_;
};

TEST_F(DomainAllocator, HeldLeasesAreDistinctAndAReleasedIdIsReused) {
  ::setenv("DDSNAV_TEST_DOMAINS", "10-14", 1);
  std::list<DomainLease> leases;  // a lease moves, but is never assigned
  std::set<int> ids;
  for (int i = 0; i < 5; ++i) {
    leases.emplace_back(0.0);
    ids.insert(leases.back().id());
  }
  EXPECT_EQ(ids, (std::set<int>{10, 11, 12, 13, 14}));
  EXPECT_THROW(DomainLease(0.2), std::runtime_error);  // pool exhausted
  const auto third = std::next(leases.begin(), 2);
  const int freed = third->id();
  leases.erase(third);
  EXPECT_EQ(DomainLease(0.0).id(), freed);
}

// An id released within the cooldown (by any process: the release time is in its lock file) is passed over while
// another is free — a test's processes may outlive its lease — and taken when none other is.
TEST_F(DomainAllocator, AnIdJustReleasedIsTakenAgainOnlyWhenNoOtherIsFree) {
  ::setenv("DDSNAV_TEST_DOMAINS", "20-21", 1);
  for (int round = 0; round < 4; ++round) {  // the scan starts at 20 in some rounds, at 21 in others
    const fs::path folder = folder_ / ("round" + std::to_string(round));
    fs::create_directories(folder);
    ::setenv("DDSNAV_TEST_DOMAIN_LOCKS", folder.c_str(), 1);
    {
      // Another process released 20 a moment ago.
      const double released = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
      std::ofstream((folder / "domain-20.lock").string(), std::ios::binary).write(reinterpret_cast<const char*>(&released), sizeof released);
    }
    DomainLease lease(0.0);
    EXPECT_EQ(lease.id(), 21) << "round " << round;
    DomainLease only_left(0.0);
    EXPECT_EQ(only_left.id(), 20) << "round " << round;
  }
}

TEST_F(DomainAllocator, NeverHandsOutTheReservedRange) {
  ::setenv("DDSNAV_TEST_DOMAINS", "226-232", 1);  // 230..232 are reserved: four ids remain
  std::list<DomainLease> leases;  // a lease moves, but is never assigned
  for (int i = 0; i < 4; ++i) {
    leases.emplace_back(0.0);
    EXPECT_TRUE(leases.back().id() < kReservedLow || leases.back().id() > kReservedHigh) << leases.back().id();
  }
  EXPECT_THROW(DomainLease(0.2), std::runtime_error);
}

TEST_F(DomainAllocator, AnIdHeldByAnotherProcessIsSkippedUntilThatProcessEnds) {
  ::setenv("DDSNAV_TEST_DOMAINS", "20-21", 1);
  int ready[2], release[2];
  ASSERT_EQ(::pipe(ready), 0);
  ASSERT_EQ(::pipe(release), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::close(release[1]);  // so that the parent closing its end is the end of the file here
    DomainLease held(0.0);
    const char id = static_cast<char>(held.id());
    (void)!::write(ready[1], &id, 1);
    char c;
    (void)!::read(release[0], &c, 1);
    ::_exit(0);
  }
  char held = 0;
  ASSERT_EQ(::read(ready[0], &held, 1), 1);
  DomainLease mine(0.0);
  EXPECT_NE(mine.id(), held);  // the only other id of the pool
  EXPECT_THROW(DomainLease(0.2), std::runtime_error);
  ::close(release[1]);  // the child ends; the kernel drops its lock
  int status = 0;
  ::waitpid(child, &status, 0);
  EXPECT_EQ(DomainLease(0.0).id(), held);
}

TEST_F(DomainAllocator, MalformedPoolIsRefusedNamingTheVariable) {
  for (const char* bad : {"abc", "5", "10-", "30-20", "0-10", "1-300"}) {
    ::setenv("DDSNAV_TEST_DOMAINS", bad, 1);
    try {
      DomainLease lease(0.0);
      ADD_FAILURE() << bad << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("DDSNAV_TEST_DOMAINS"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
