// Shared by the bus tests: domain ids (one per test so `ctest -j2` never mixes them) and vendor pairs.
#pragma once

#include <ddsnav/bus/bus.hpp>
#include <ddsnav/testing/domain.hpp>

#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <string>

namespace ddsnav::test {

using namespace std::chrono_literals;

// The domain id of a test's participants: `key` names one domain within this test process (participants
// that should meet pass the same key); the id comes from the allocator (ddsnav/testing/domain.hpp) and is
// held until the process ends, so tests running side by side never share one.
inline int testDomain(int key) {
  static std::mutex mutex;
  static std::map<int, std::unique_ptr<testing::DomainLease>> leases;
  std::lock_guard lock(mutex);
  auto& lease = leases[key];
  if (!lease) lease = std::make_unique<testing::DomainLease>();
  return lease->id();
}

// Generous bound for discovery + delivery; tests wait on events and return as soon as they happen.
inline constexpr auto kWait = std::chrono::milliseconds(10000);

inline bus::ParticipantOptions options(bus::Vendor vendor, int domain_offset, const std::string& name) {
  bus::ParticipantOptions o;
  o.vendor = vendor;
  o.domain_id = testDomain(domain_offset);
  o.name = name;
  return o;
}

inline std::string vendorTag(bus::Vendor v) { return v == bus::Vendor::FastDDS ? "Fast" : "Cyclone"; }

}  // namespace ddsnav::test
