#pragma once
// A world the planner tries before the plain map (the unknown margin, the hidden continuation; docs/world-model.md)
// and its share of a request's budget, from what its recent searches took.
//
// The share: a tenth of what is left, 0.1 s at most before a search there has succeeded (the continuation world,
// tried for the first time with 0.28 s of preferred_worlds_s left, held bugtrap_0.4 replans that long failing), an
// eighth of that for each failure since the last success (down to 50 ms);
// once solves there have succeeded, at most 3 x their median (at least 20 ms), also after failures, and down to
// that (at most 0.1 s). Where such a world closes an unseen passage the vehicle must take, it finds nothing and the
// whole share is waited for before the next world is tried: 0.5 s of a 5 s budget on stunnel_1.0, the worst replan
// of that run, where the successful solves took 11-125 ms; in stunnel_0.5's 2 m corridor, whose next leg the margin
// closes until the vehicle looks into it, most tries fail, and 0.1 s went to each of 15 of 25 requests (the
// successes took 2-29 ms) and 0.5 s to the first failure after each success: most of those replans' scan ->
// trajectory latency (p99 313-560 ms). Halved, then quartered per failure, the first replans of a mission, before
// any success, still waited 0.25 / 0.125 s (p99 164-191 ms). A search that would have succeeded later is cut off
// and the next world answers.

#include <deque>

namespace ddsnav::nodes {

class WorldTier {
 public:
  // Seconds of `left` (the request's budget not yet spent) this world may search.
  double share(double left) const;
  void solved(double seconds);  // a search here found a path in `seconds`
  void failed();                // a search here used its whole share without a path
  int failuresInARow() const { return failures_; }

  static constexpr double kShareBeforeASolve_s = 0.1;

 private:
  std::deque<double> solve_s_;  // the latest successful solves, s (at most 15)
  int failures_ = 0;            // failed searches since the last success
};

}  // namespace ddsnav::nodes
