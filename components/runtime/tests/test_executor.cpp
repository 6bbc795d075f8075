// The executor and the worker without DDS: queue overflow (keep-last drops the oldest and counts it),
// timers, posted tasks, exceptions, and the worker's supersede/cancel contract with a real planner solve.
#include <ddsnav/runtime/executor.hpp>
#include <ddsnav/runtime/pending_work.hpp>

#include <ddsnav/planner/planner.hpp>
#include <ddsnav/planner/planners.hpp>
#include <ddsnav/planner/scenario.hpp>

#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <future>
#include <memory>
#include <optional>
#include <thread>

namespace ddsnav::runtime {
namespace {

using namespace std::chrono_literals;
using detail::TypedQueue;

// How many times slower than the plain build this run is: scripts/sanitize sets DDSNAV_TEST_TIME_FACTOR
// (docs/fuzzing.md), since an instrumented build does the same work several times slower. Bounds on how
// long something takes scale with it; what must happen does not change.
double timeFactor() {
  const char* text = std::getenv("DDSNAV_TEST_TIME_FACTOR");
  const double factor = text != nullptr ? std::atof(text) : 1.0;
  return factor >= 1.0 && factor <= 100.0 ? factor : 1.0;
}

// A queue filled by hand, as the bus callback would (the callback is exercised over DDS in test_subscribe).
struct HandQueue {
  std::shared_ptr<TypedQueue<int>> queue;
  void push(int v) { queue->push(std::make_shared<const int>(v), {}, queue); }
};

TEST(Executor, FullQueueDropsTheOldestAndCountsIt) {
  Executor executor;
  std::vector<int> seen;
  // Executor::subscribe builds the same queue over a bus subscription; here it is filled directly.
  auto queue = std::make_shared<TypedQueue<int>>("test/ints", 3, [&](std::shared_ptr<const int> v, const bus::SampleInfo&) { seen.push_back(*v); },
                                                  std::weak_ptr<detail::ExecutorCore>());
  HandQueue q{queue};
  for (int i = 1; i <= 5; ++i) q.push(i);  // nobody runs the executor meanwhile: 1 and 2 are dropped
  const auto stats = queue->stats();
  EXPECT_EQ(stats.received, 5u);
  EXPECT_EQ(stats.dropped, 2u);
  while (queue->runOne()) {
  }
  EXPECT_EQ(seen, (std::vector<int>{3, 4, 5}));
}

TEST(Executor, TimersTickAtTheirPeriodOnTheExecutorThread) {
  Executor executor;
  std::atomic<int> ticks{0};
  std::thread::id tick_thread;
  const auto started = std::chrono::steady_clock::now();
  std::chrono::steady_clock::duration tenth{};
  Timer timer = executor.every(20ms, [&] {
    tick_thread = std::this_thread::get_id();
    if (++ticks == 10) {
      tenth = std::chrono::steady_clock::now() - started;
      executor.stop();
    }
  });
  std::thread runner([&] { executor.run(); });
  const auto runner_id = runner.get_id();
  runner.join();
  EXPECT_EQ(ticks.load(), 10);
  EXPECT_EQ(tick_thread, runner_id);
  // Ten periods of 20 ms: not before 200 ms (a timer never fires early); the upper bound is generous.
  EXPECT_GE(tenth, 200ms);
  EXPECT_LT(tenth, 5s);
}

TEST(Executor, CancelledTimerStopsTicking) {
  Executor executor;
  std::atomic<int> ticks{0};
  Timer timer = executor.every(5ms, [&] { ++ticks; });
  Timer stopper = executor.every(100ms, [&] { executor.stop(); });
  timer.cancel();
  executor.run();
  EXPECT_EQ(ticks.load(), 0);
}

TEST(Executor, PostedTasksRunInOrderAndATimerExceptionEndsRun) {
  Executor executor;
  std::vector<int> order;
  for (int i = 0; i < 5; ++i) executor.post([&, i] { order.push_back(i); });
  Timer failing = executor.every(10ms, [] { throw std::runtime_error("mission failed"); });
  EXPECT_THROW(executor.run(), std::runtime_error);
  EXPECT_EQ(order, (std::vector<int>{0, 1, 2, 3, 4}));
  EXPECT_FALSE(executor.running());
}

TEST(Executor, ATimerAlwaysDueDoesNotStarveTheQueue) {
  // A timer whose callback outlasts its period is always due (the simulator's step with a slow 3-D scan);
  // a task posted meanwhile must still run after at most one more tick, not only once the timer gives up
  // catching up (after ~500 ms of backlog, some 150 ticks here).
  Executor executor;
  int ticks = 0;
  int posted_at = -1, ran_at = -1;
  Timer busy = executor.every(1ms, [&] {
    std::this_thread::sleep_for(3ms);
    ++ticks;
    if (ticks == 5) {
      posted_at = ticks;
      executor.post([&] { ran_at = ticks; });
    }
    if (ran_at >= 0 || ticks > 400) executor.stop();
  });
  executor.run();
  ASSERT_EQ(posted_at, 5);
  ASSERT_GE(ran_at, 5) << "the posted task never ran while the timer was due";
  EXPECT_LE(ran_at, posted_at + 1);
}

TEST(Executor, StopBeforeRunReturnsAtOnce) {
  Executor executor;
  executor.stop();
  executor.run();  // must not block
  SUCCEED();
}

// A problem no planner solves: start and goal in two closed rooms of a 2-D world.
planner::Scenario walledOff() {
  return planner::parseScenario(R"(
name: walled
dimensions: 2
bounds: {min: [0, 0], max: [20, 20]}
start: [2, 2]
goal: [18, 18]
goal_radius: 0.5
robot_radius: 0.1
obstacles:
  - {type: box, min: [9, 0], max: [11, 20]}
)", "walled.yaml");
}

TEST(Worker, ANewerJobOfTheSameKeyStopsTheRunningSolveWithinTenMilliseconds) {
  const auto scenario = walledOff();
  const auto world = planner::makeScenarioWorld(scenario);
  Worker worker("planner");
  std::promise<planner::PlanResult> first_result;
  std::promise<void> first_started;
  std::atomic<std::int64_t> stop_requested_ns{0}, first_returned_ns{0};
  const auto now_ns = [] { return std::chrono::steady_clock::now().time_since_epoch().count(); };
  worker.submit(7, [&](std::stop_token stop) {
    planner::PlanProblem problem = planner::problemFromScenario(scenario, *world);
    problem.time_limit_s = 30;  // long: only the stop ends it
    problem.stop = stop;
    first_started.set_value();
    auto result = planner::makePlanner("rrt")->solve(problem);
    first_returned_ns = now_ns();
    first_result.set_value(std::move(result));
  });
  first_started.get_future().wait();
  std::this_thread::sleep_for(200ms);  // well inside the search
  std::promise<bool> second_stopped;
  stop_requested_ns = now_ns();
  worker.submit(7, [&](std::stop_token stop) { second_stopped.set_value(stop.stop_requested()); });
  const auto result = first_result.get_future().get();
  EXPECT_TRUE(result.stopped);
  EXPECT_FALSE(result.solved);
  EXPECT_FALSE(second_stopped.get_future().get());  // the newer one runs normally
  const double stop_ms = (first_returned_ns - stop_requested_ns) / 1e6;
  EXPECT_LT(stop_ms, 10.0 * timeFactor()) << "the superseded solve took " << stop_ms << " ms to stop";
}

TEST(Worker, OtherKeysWaitTheirTurnAndStopEndsEverything) {
  Worker worker;
  std::promise<void> release;
  auto released = release.get_future().share();
  std::vector<std::pair<int, bool>> ran;  // (job, stopped when it ran)
  std::mutex mutex;
  std::promise<void> all_ran;
  const auto job = [&](int id, bool wait) {
    return [&, id, wait](std::stop_token stop) {
      if (wait) released.wait();
      std::lock_guard lock(mutex);
      ran.emplace_back(id, stop.stop_requested());
      if (ran.size() == 4) all_ran.set_value();
    };
  };
  worker.submit(1, job(1, true));
  worker.submit(2, job(2, false));  // another requester: not stopped, runs after 1
  worker.submit(3, job(3, false));
  worker.submit(3, job(4, false));  // supersedes 3 before it started: 3 still runs, stopped
  release.set_value();
  all_ran.get_future().wait();
  worker.stop();
  ASSERT_EQ(ran.size(), 4u);
  EXPECT_EQ(ran[0], std::make_pair(1, false));
  EXPECT_EQ(ran[1], std::make_pair(2, false));
  EXPECT_EQ(ran[2], std::make_pair(3, true));
  EXPECT_EQ(ran[3], std::make_pair(4, false));
  EXPECT_TRUE(worker.stopping());
  EXPECT_THROW(worker.submit(5, job(5, false)), std::logic_error);
}

// What system/progress reports as the oldest pending work (docs/simulator.md, "Pacing"): jobs queued or running on
// any Worker and PendingWork tokens, each stamped with the work clock when made; nothing without a clock.
TEST(ProgressWork, WorkersJobsAndPendingWorkAreStampedWithTheWorkClockUntilTheyAreDone) {
  EXPECT_FALSE(oldestPendingWork());
  std::atomic<std::int64_t> now{100};
  setWorkClock([&] { return now.load(); });
  EXPECT_FALSE(oldestPendingWork());  // idle
  {
    auto token = std::make_unique<PendingWork>();
    now = 200;
    PendingWork later;
    EXPECT_EQ(oldestPendingWork(), std::optional<std::int64_t>(100));
    token.reset();
    EXPECT_EQ(oldestPendingWork(), std::optional<std::int64_t>(200));
  }
  EXPECT_FALSE(oldestPendingWork());
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  std::atomic<bool> started{false};
  {
    Worker worker("progress-test");
    now = 300;
    worker.submit(1, [&](std::stop_token) {
      started = true;
      released.wait();
    });
    while (!started) std::this_thread::yield();
    EXPECT_EQ(oldestPendingWork(), std::optional<std::int64_t>(300));
    release.set_value();
    for (int i = 0; i < 1000 && oldestPendingWork(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    EXPECT_FALSE(oldestPendingWork());
  }
  setWorkClock({});
  PendingWork unstamped;
  EXPECT_FALSE(oldestPendingWork());
}

}  // namespace
}  // namespace ddsnav::runtime
