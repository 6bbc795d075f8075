#pragma once
// Li-RRT: liveness-based RRT (Li-RRT paper, Algorithms 2 and 3) on the unicycle edge model.
//
// Every tree node carries the liveness of eq. 6,
//   LnLi(x) = ln Se(x) - [ m_h(x) + d(x) + d_s(x) / n_t ],
// with Se the fraction of the discrete control set U whose one-step edges are collision free (eq. 3),
// d the number of children, d_s the offspring term of eq. 4 (the sum of the degrees of all descendants,
// i.e. the number of descendants that are not direct children), m_h the number of other nodes within the
// neighbour radius H, and n_t the tree size. A node with Se = 0 is dead: LnLi = -inf, never expanded.

#include "ddsnav/planner/planner.hpp"
#include "ddsnav/planner/unicycle.hpp"

#include <cstdint>
#include <queue>
#include <vector>

namespace ddsnav::planner {

// The liveness bookkeeping of Algorithm 3 over node ids 0, 1, 2, ... (0 is the root).
//
// Keeping the priority structure consistent: d_s/n_t changes for *every* node whenever n_t grows, so an
// exact heap keyed by LnLi would need a full rebuild per insertion. Instead each heap entry is keyed by
// the part of LnLi that only changes on the events Algorithm 3 lists,
//   bound(x) = ln Se(x) - m_h(x) - d(x)  >=  LnLi(x)      (because 0 <= d_s/n_t < 1),
// and re-pushed with a new version stamp when d or m_h changes (parent, near set); stale entries are
// skipped when they surface. mostAlive() pops entries in bound order, evaluates the exact LnLi at the
// current n_t, and stops as soon as the next bound cannot beat the best exact value: the result is the
// exact argmax of eq. 6, not an approximation. The ancestors' offspring update (V2ch) only increments
// integers; it never touches the heap because it does not change their bound.
class LivenessBook {
 public:
  // Adds a node. parent: its parent id (-1 for the root); se: its Se in [0, 1]; near: ids of existing
  // nodes within H of it (its neighbour set, V3ch). Applies UpdateLi and returns the new id.
  int add(int parent, double se, const std::vector<int>& near);

  int size() const { return static_cast<int>(nodes_.size()); }
  double se(int id) const { return nodes_[id].se; }
  int degree(int id) const { return nodes_[id].degree; }
  int offspring(int id) const { return nodes_[id].offspring; }
  int neighbourCollisions(int id) const { return nodes_[id].neighbours; }
  bool dead(int id) const { return nodes_[id].se <= 0.0; }

  // Lowers a node's Se when one of its controls turned out to lead only to a dead successor (a dead node
  // is an "inevitable obstacle", Section 3.3.1, so that control no longer counts as free). Se = 0 kills it.
  void reduceSe(int id, double se);

  // Eq. 6 at the current tree size; -inf for a dead node.
  double lnLi(int id) const;

  // The node of largest LnLi (ties: smallest id), or -1 when every node is dead.
  int mostAlive();

 private:
  struct Node {
    int parent = -1;
    double se = 0.0;
    double ln_se = 0.0;
    int degree = 0;
    int offspring = 0;
    int neighbours = 0;
    std::uint32_t version = 0;
  };
  struct Entry {
    double bound;
    int id;
    std::uint32_t version;
    // Max-heap on bound, then smaller id first.
    bool operator<(const Entry& o) const { return bound != o.bound ? bound < o.bound : id > o.id; }
  };
  double bound(const Node& n) const { return n.ln_se - n.neighbours - n.degree; }
  void push(int id);
  void compactIfNeeded();

  std::vector<Node> nodes_;
  std::priority_queue<Entry> heap_;
  std::vector<Entry> popped_;  // scratch for mostAlive
  int alive_ = 0;
};

struct LirrtOptions {
  double drive_probability = 0.5;  // B: drive the most alive node with a random control
  double goal_bias = 0.1;          // W: sample the goal
  double neighbour_radius = 0.5;   // H, as a fraction of the reach v_max*dt
  int turn_steps = 5;              // controls: turns evenly spread over [-max_turn, max_turn]
  int speed_steps = 4;             // controls: lengths reach / 2^k, k = 0..speed_steps-1
  int climb_steps = 3;             // 3-D controls: climbs evenly spread over [-max_climb, max_climb]
};

// One discrete control: a turn (rad), a horizontal length (m) and a climb (m) for one edge.
struct UnicycleControl {
  double turn = 0.0;
  double length = 0.0;
  double climb = 0.0;
};

// The discrete control set U of eq. 3 for a forward region.
std::vector<UnicycleControl> lirrtControlSet(const ForwardRegion& region, const LirrtOptions& options);

class LirrtPlanner : public Planner {
 public:
  explicit LirrtPlanner(LirrtOptions options = {});
  std::string name() const override { return "lirrt"; }
  PlanResult solve(const PlanProblem& problem) override;

 private:
  LirrtOptions options_;
};

}  // namespace ddsnav::planner
