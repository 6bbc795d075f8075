#pragma once
// DDS domain ids for tests, handed out so that no two tests running at the same time share one: across
// threads, test binaries and `ctest -j` (each id is held through an flock()ed file, released when the
// lease ends or the process dies, however it dies).
//
//   ddsnav::testing::DomainLease domain;            // a free id of the pool
//   bus::Participant p({.domain_id = domain.id()});
//
// The pool is kMinTestDomain..kMaxTestDomain, minus kReservedLow..kReservedHigh and kFixedLow..kFixedHigh (ids
// picked by hand elsewhere). DDSNAV_TEST_DOMAINS=LOW-HIGH narrows it (it can only narrow: the reserved ids stay out).
// Lock files live in DDSNAV_TEST_DOMAIN_LOCKS, default <temp dir>/ddsnav-test-domains.

#include <string>

namespace ddsnav::testing {

inline constexpr int kMinTestDomain = 1;     // 0 is the default domain of demos and users
inline constexpr int kMaxTestDomain = 232;   // bus::kMaxDomainId
inline constexpr int kReservedLow = 230;     // hand-picked ids of tests that predate the allocator
inline constexpr int kReservedHigh = 259;
// Also hand-picked, by the security and network tests (131-140) and the mission tests (140-142).
inline constexpr int kFixedLow = 130;
inline constexpr int kFixedHigh = 142;

class DomainLease {
 public:
  // Takes a free id (not the one released last, and one released within the last 30 s only when no other is free:
  // the processes of the test that held it may still be shutting down); waits up to `timeout_s` for one to free up, then throws std::runtime_error
  // naming the pool and the lock folder.
  explicit DomainLease(double timeout_s = 120.0);
  ~DomainLease();
  DomainLease(DomainLease&& other) noexcept;
  DomainLease& operator=(DomainLease&&) = delete;
  DomainLease(const DomainLease&) = delete;
  DomainLease& operator=(const DomainLease&) = delete;

  int id() const { return id_; }
  std::string str() const { return std::to_string(id_); }

 private:
  int id_ = -1;
  int fd_ = -1;
};

// The pool after DDSNAV_TEST_DOMAINS, as [low, high]; throws std::invalid_argument naming the variable
// for a malformed or empty range. Exposed for the harness's own tests.
struct DomainPool {
  int low;
  int high;
  bool contains(int id) const { return id >= low && id <= high && (id < kReservedLow || id > kReservedHigh) && (id < kFixedLow || id > kFixedHigh); }
};
DomainPool domainPoolFromEnvironment();

}  // namespace ddsnav::testing
