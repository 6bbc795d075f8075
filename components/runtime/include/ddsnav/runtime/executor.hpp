// Where a component's code runs: its executor's thread, never a DDS vendor thread.
//
// A subscription made through the executor (Context::subscribe) only puts the sample into that
// subscription's queue on the vendor thread (a shared object: a copy of what DDS delivered, or the
// publisher's own object when it came intra-process, bus.hpp); the executor's thread takes samples, timers and posted tasks
// in arrival order and runs the callbacks, one at a time. So a component's callbacks never overlap and
// need no locks among themselves. Each queue holds at most its QoS depth (every ddsnav profile is
// KEEP_LAST): when a sample arrives at a full queue the oldest one is dropped and counted (queueStats(),
// and the system/status heartbeat's detail says so).
//
// Long work (a plan) goes to a Worker instead, so that the executor keeps taking samples meanwhile.
//
// Errors: an exception from a subscription callback is logged (naming the topic) and the sample skipped,
// as the bus does; one from a timer or a posted task stops the executor and is rethrown by run(), so it
// ends the component like an exception from its main loop did (FAILED on system/status).
#pragma once

#include <ddsnav/bus/bus.hpp>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <exception>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stop_token>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace ddsnav::runtime {

struct QueueStats {
  std::string topic;
  std::size_t depth = 0;
  std::uint64_t received = 0;  // samples handed over by the bus
  std::uint64_t dropped = 0;   // oldest samples dropped because the queue was full
};

namespace detail {

class ExecutorCore;

class SampleQueue {
 public:
  SampleQueue(std::string topic, std::size_t depth) : topic_(std::move(topic)), depth_(depth < 1 ? 1 : depth) {}
  virtual ~SampleQueue() = default;
  // Takes the oldest sample and runs the callback on it (on the executor thread); false when empty.
  virtual bool runOne() = 0;
  QueueStats stats() const { return {topic_, depth_, received_.load(), dropped_.load()}; }
  const std::string& topic() const { return topic_; }

 protected:
  std::string topic_;
  std::size_t depth_;
  std::atomic<std::uint64_t> received_{0}, dropped_{0};
};

class ExecutorCore : public std::enable_shared_from_this<ExecutorCore> {
 public:
  using Clock = std::chrono::steady_clock;
  struct Timer {
    std::chrono::nanoseconds period;
    Clock::time_point next;
    std::function<void()> fn;
  };

  void post(std::function<void()> task);
  void sampleReady(std::shared_ptr<SampleQueue> queue);
  void registerQueue(const std::shared_ptr<SampleQueue>& queue);
  std::uint64_t addTimer(std::chrono::nanoseconds period, std::function<void()> fn);
  void cancelTimer(std::uint64_t id);
  void run();
  void stop();
  bool running() const { return running_.load(); }
  std::thread::id threadId() const;
  std::vector<QueueStats> queueStats() const;

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  // Samples (one entry per queued sample) and posted tasks, in arrival order.
  struct Ready {
    std::shared_ptr<SampleQueue> queue;
    std::function<void()> task;
  };
  std::deque<Ready> ready_;
  std::map<std::uint64_t, Timer> timers_;
  std::uint64_t next_timer_id_ = 1;
  std::vector<std::weak_ptr<SampleQueue>> queues_;
  bool stop_ = false;
  std::atomic<bool> running_{false};
  std::thread::id thread_;
};

template <class T>
class TypedQueue : public SampleQueue {
 public:
  using Callback = std::function<void(std::shared_ptr<const T>, const bus::SampleInfo&)>;
  TypedQueue(std::string topic, std::size_t depth, Callback callback, std::weak_ptr<ExecutorCore> core)
      : SampleQueue(std::move(topic), depth), callback_(std::move(callback)), core_(std::move(core)) {}

  // On the vendor (or, intra-process, the publisher's) thread: into the queue, nothing else.
  void push(std::shared_ptr<const T> sample, const bus::SampleInfo& info, const std::shared_ptr<SampleQueue>& self) {
    bool added = true;
    {
      std::lock_guard lock(mutex_);
      if (items_.size() >= depth_) {
        items_.pop_front();  // KEEP_LAST: the newest samples matter
        added = false;
        dropped_.fetch_add(1, std::memory_order_relaxed);
      }
      items_.emplace_back(std::move(sample), info);
    }
    received_.fetch_add(1, std::memory_order_relaxed);
    if (added)
      if (auto core = core_.lock()) core->sampleReady(self);
  }

  bool runOne() override {
    std::optional<std::pair<std::shared_ptr<const T>, bus::SampleInfo>> item;
    {
      std::lock_guard lock(mutex_);
      if (items_.empty()) return false;
      item.emplace(std::move(items_.front()));
      items_.pop_front();
    }
    callback_(std::move(item->first), item->second);
    return true;
  }

 private:
  std::mutex mutex_;
  std::deque<std::pair<std::shared_ptr<const T>, bus::SampleInfo>> items_;
  Callback callback_;
  std::weak_ptr<ExecutorCore> core_;
};

}  // namespace detail

// A timer of an executor; stops when destroyed (or reset).
class Timer {
 public:
  Timer() = default;
  Timer(std::weak_ptr<detail::ExecutorCore> core, std::uint64_t id) : core_(std::move(core)), id_(id) {}
  Timer(Timer&& other) noexcept { *this = std::move(other); }
  Timer& operator=(Timer&& other) noexcept {
    if (this != &other) {
      cancel();
      core_ = std::move(other.core_);
      id_ = std::exchange(other.id_, 0);
    }
    return *this;
  }
  ~Timer() { cancel(); }
  void cancel() {
    if (auto core = core_.lock(); core && id_) core->cancelTimer(id_);
    id_ = 0;
  }

 private:
  std::weak_ptr<detail::ExecutorCore> core_;
  std::uint64_t id_ = 0;
};

class Executor {
 public:
  Executor() : core_(std::make_shared<detail::ExecutorCore>()) {}
  ~Executor() { stop(); }
  Executor(const Executor&) = delete;
  Executor& operator=(const Executor&) = delete;

  // A subscription whose callback runs on this executor; the queue holds up to qos.depth samples. The
  // callback takes (const T&), (const T&, const SampleInfo&) or (std::shared_ptr<const T>, const SampleInfo&).
  template <class T, class Callback>
  bus::Subscription subscribe(bus::Participant& participant, const std::string& topic, const bus::Qos& qos, Callback callback) {
    typename detail::TypedQueue<T>::Callback erased;
    if constexpr (std::is_invocable_v<Callback&, std::shared_ptr<const T>, const bus::SampleInfo&>) {
      erased = std::move(callback);  // takes the shared object: may keep or republish it without a copy
    } else if constexpr (std::is_invocable_v<Callback&, const T&, const bus::SampleInfo&>) {
      erased = [cb = std::move(callback)](std::shared_ptr<const T> s, const bus::SampleInfo& info) mutable { cb(*s, info); };
    } else {
      static_assert(std::is_invocable_v<Callback&, const T&>, "callback must take (const T&) or (const T&, const SampleInfo&)");
      erased = [cb = std::move(callback)](std::shared_ptr<const T> s, const bus::SampleInfo&) mutable { cb(*s); };
    }
    auto queue = std::make_shared<detail::TypedQueue<T>>(topic, static_cast<std::size_t>(qos.depth), std::move(erased), core_);
    core_->registerQueue(queue);
    // The bus callback holds the queue; the queue only a weak reference to the executor.
    return participant.subscribeShared<T>(topic, qos, [queue](std::shared_ptr<const T> sample, const bus::SampleInfo& info) {
      queue->push(std::move(sample), info, queue);
    });
  }

  // Runs `task` on the executor thread, after the samples that arrived before it.
  void post(std::function<void()> task) { core_->post(std::move(task)); }
  // Calls fn every period, the first time one period from now. Late ticks are not made up: after a stall
  // of more than max(period, 0.5 s) the timer restarts from now.
  [[nodiscard]] Timer every(std::chrono::nanoseconds period, std::function<void()> fn) {
    return Timer(core_, core_->addTimer(period, std::move(fn)));
  }

  // Runs callbacks on the calling thread until stop(); rethrows a timer's or task's exception.
  void run() { core_->run(); }
  // From any thread (a callback included): run() returns after the callback in progress.
  void stop() { core_->stop(); }
  bool running() const { return core_->running(); }
  // The thread inside run() (a default id when none).
  std::thread::id threadId() const { return core_->threadId(); }
  std::vector<QueueStats> queueStats() const { return core_->queueStats(); }

 private:
  std::shared_ptr<detail::ExecutorCore> core_;
};

// Long work off the executor, one job at a time in submission order, on the worker's own thread. A job
// is given a stop token: submitting another job under the same key (the same requester) requests a stop
// of the queued or running one, and so does stop(). A job checks the token (PlanProblem::stop) and returns
// promptly; it still runs when stopped before it started, so that it can answer its requester.
// Every Worker of the process stamps each job with the time of workClock() when it is submitted, so that
// how far the process is behind its clock can be told (system/progress, docs/simulator.md "Pacing"). The
// component's runtime sets the clock when it follows system/clock; without one, jobs carry no stamp.
void setWorkClock(std::function<std::int64_t()> now);
// The earliest stamp of a job queued or running on any Worker of the process; nullopt when every Worker is idle
// (or no clock is set).
std::optional<std::int64_t> oldestPendingWork();

class Worker {
 public:
  using Job = std::function<void(std::stop_token)>;
  explicit Worker(std::string name = "worker");
  ~Worker();
  // The earliest work-clock stamp among this worker's queued and running jobs (0: unstamped), nullopt when idle.
  std::optional<std::int64_t> pendingSince() const;
  Worker(const Worker&) = delete;
  Worker& operator=(const Worker&) = delete;

  void submit(std::uint64_t key, Job job);
  // Stops every job (queued ones run stopped), then joins the thread. Safe to call twice.
  void stop();
  // True once stop() was called: a stopped job tells "superseded" from "shutting down" with it.
  bool stopping() const { return stopping_.load(); }
  std::thread::id threadId() const { return thread_.get_id(); }

 private:
  struct Entry {
    std::uint64_t key;
    std::stop_source stop;
    Job job;
    std::int64_t submitted_ns = 0;  // workClock() at submit
  };
  void loop();

  std::string name_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::shared_ptr<Entry>> queue_;
  std::shared_ptr<Entry> running_;
  std::atomic<bool> stopping_{false};
  bool finished_ = false;
  std::thread thread_;
};

}  // namespace ddsnav::runtime
