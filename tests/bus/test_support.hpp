// Shared by the bus tests: domain ids (one per test so `ctest -j2` never mixes them) and vendor pairs.
#pragma once

#include <ddsnav/bus/bus.hpp>

#include <chrono>
#include <string>

namespace ddsnav::test {

using namespace std::chrono_literals;

// Bus tests use domains 150..189 (offsets 0..39); every test takes its own. tests/record uses 190..199,
// tests/pipeline 200..219: ctest runs suites side by side, so the ranges must not overlap.
inline constexpr int kDomainBase = 150;

// Generous bound for discovery + delivery; tests wait on events and return as soon as they happen.
inline constexpr auto kWait = std::chrono::milliseconds(10000);

inline bus::ParticipantOptions options(bus::Vendor vendor, int domain_offset, const std::string& name) {
  bus::ParticipantOptions o;
  o.vendor = vendor;
  o.domain_id = kDomainBase + domain_offset;
  o.name = name;
  return o;
}

inline std::string vendorTag(bus::Vendor v) { return v == bus::Vendor::FastDDS ? "Fast" : "Cyclone"; }

}  // namespace ddsnav::test
