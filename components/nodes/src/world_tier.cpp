#include "ddsnav/nodes/world_tier.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace ddsnav::nodes {

double WorldTier::share(double left) const {
  double share = left / 10;
  double floor = 0.05;
  if (solve_s_.empty()) {
    share = std::min(share, kShareBeforeASolve_s);
  } else {
    std::vector<double> sorted(solve_s_.begin(), solve_s_.end());
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
    const double typical = std::max(0.02, 3.0 * sorted[sorted.size() / 2]);
    share = std::min(share, typical);
    floor = std::min(0.1, typical);
  }
  return std::max(std::min(share, floor), std::ldexp(share, -3 * std::min(failures_, 30)));
}

void WorldTier::solved(double seconds) {
  failures_ = 0;
  solve_s_.push_back(seconds);
  if (solve_s_.size() > 15) solve_s_.pop_front();
}

void WorldTier::failed() { ++failures_; }

}  // namespace ddsnav::nodes
