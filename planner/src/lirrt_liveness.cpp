// Li-RRT liveness bookkeeping (eqs. 3-6, Algorithm 3) and its discrete control set.
#include "ddsnav/planner/lirrt.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace ddsnav::planner {

int LivenessBook::add(int parent, double se, const std::vector<int>& near) {
  if (!(se >= 0.0 && se <= 1.0)) throw std::invalid_argument("LivenessBook::add: Se must be in [0, 1]");
  if (parent < -1 || parent >= size()) throw std::invalid_argument("LivenessBook::add: unknown parent");
  const int id = size();
  Node node;
  node.parent = parent;
  node.se = se;
  node.ln_se = se > 0.0 ? std::log(se) : -std::numeric_limits<double>::infinity();
  node.neighbours = static_cast<int>(near.size());  // Algorithm 3 line 1: m_h of the new node
  nodes_.push_back(node);
  if (se > 0.0) {
    ++alive_;
    push(id);
  }
  if (parent >= 0) {
    // Line 6: the parent gained a child (d + 1, so LnLi - 1).
    ++nodes_[parent].degree;
    push(parent);
    // Lines 2-4: every further ancestor gained an offspring (d_s + 1). Their heap bound is unchanged.
    for (int a = nodes_[parent].parent; a >= 0; a = nodes_[a].parent) ++nodes_[a].offspring;
  }
  // Lines 7-9: each neighbour within H sees one more neighbour collision (m_h + 1, so LnLi - 1).
  for (int n : near) {
    if (n < 0 || n >= id) throw std::invalid_argument("LivenessBook::add: unknown neighbour");
    ++nodes_[n].neighbours;
    push(n);
  }
  compactIfNeeded();
  return id;
}

void LivenessBook::reduceSe(int id, double se) {
  Node& n = nodes_[id];
  if (!(se >= 0.0 && se <= n.se)) throw std::invalid_argument("LivenessBook::reduceSe: Se may only decrease");
  if (n.se > 0.0 && se <= 0.0) --alive_;
  n.se = se;
  n.ln_se = se > 0.0 ? std::log(se) : -std::numeric_limits<double>::infinity();
  push(id);  // new bound, or (dead) just invalidates the old entries
}

double LivenessBook::lnLi(int id) const {
  const Node& n = nodes_[id];
  if (n.se <= 0.0) return -std::numeric_limits<double>::infinity();
  return n.ln_se - (n.neighbours + n.degree + static_cast<double>(n.offspring) / size());
}

void LivenessBook::push(int id) {
  Node& n = nodes_[id];
  ++n.version;  // earlier entries of this node are stale from now on
  if (n.se > 0.0) heap_.push({bound(n), id, n.version});
}

int LivenessBook::mostAlive() {
  int best = -1;
  double best_value = -std::numeric_limits<double>::infinity();
  popped_.clear();
  while (!heap_.empty()) {
    const Entry top = heap_.top();
    if (nodes_[top.id].version != top.version) {  // stale
      heap_.pop();
      continue;
    }
    // bound >= LnLi: nothing below this entry can beat an exact value at least as large.
    if (best >= 0 && top.bound < best_value) break;
    if (best >= 0 && top.bound == best_value && top.id > best) break;
    heap_.pop();
    popped_.push_back(top);
    const double value = lnLi(top.id);
    if (best < 0 || value > best_value || (value == best_value && top.id < best)) {
      best = top.id;
      best_value = value;
    }
  }
  for (const Entry& e : popped_) heap_.push(e);
  return best;
}

void LivenessBook::compactIfNeeded() {
  // Stale entries accumulate (one per parent / neighbour update); rebuild when they dominate.
  if (heap_.size() < 64 || heap_.size() < 4 * static_cast<std::size_t>(alive_)) return;
  std::vector<Entry> live;
  live.reserve(alive_);
  while (!heap_.empty()) {
    if (nodes_[heap_.top().id].version == heap_.top().version) live.push_back(heap_.top());
    heap_.pop();
  }
  heap_ = std::priority_queue<Entry>(std::less<Entry>(), std::move(live));
}

std::vector<UnicycleControl> lirrtControlSet(const ForwardRegion& region, const LirrtOptions& options) {
  if (options.turn_steps < 1 || options.speed_steps < 1 || options.climb_steps < 1) {
    throw std::invalid_argument("Li-RRT control set needs at least one turn, speed and climb step");
  }
  auto spread = [](int steps, double limit, int k) {
    return steps == 1 ? 0.0 : -limit + 2.0 * limit * k / (steps - 1);
  };
  const int climbs = region.dimensions == 3 ? options.climb_steps : 1;
  std::vector<UnicycleControl> controls;
  for (int s = 1; s <= options.speed_steps; ++s) {
    for (int t = 0; t < options.turn_steps; ++t) {
      for (int c = 0; c < climbs; ++c) {
        UnicycleControl u;
        // Lengths halve from the full reach: short steps keep nodes alive in passages narrower than an edge.
        u.length = region.reach / std::pow(2.0, options.speed_steps - s);
        u.turn = spread(options.turn_steps, region.max_turn, t);
        u.climb = region.dimensions == 3 ? spread(climbs, region.max_climb, c) : 0.0;
        controls.push_back(u);
      }
    }
  }
  if (controls.size() > 64) throw std::invalid_argument("Li-RRT control set is limited to 64 controls");
  return controls;
}

}  // namespace ddsnav::planner
