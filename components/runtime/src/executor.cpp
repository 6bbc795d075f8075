#include <ddsnav/runtime/executor.hpp>
#include <ddsnav/runtime/pending_work.hpp>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <map>

namespace ddsnav::runtime {
namespace detail {

using namespace std::chrono_literals;

void ExecutorCore::post(std::function<void()> task) {
  {
    std::lock_guard lock(mutex_);
    ready_.push_back({nullptr, std::move(task)});
  }
  changed_.notify_one();
}

void ExecutorCore::sampleReady(std::shared_ptr<SampleQueue> queue) {
  {
    std::lock_guard lock(mutex_);
    if (stop_) return;
    ready_.push_back({std::move(queue), {}});
  }
  changed_.notify_one();
}

void ExecutorCore::registerQueue(const std::shared_ptr<SampleQueue>& queue) {
  std::lock_guard lock(mutex_);
  std::erase_if(queues_, [](const std::weak_ptr<SampleQueue>& q) { return q.expired(); });
  queues_.push_back(queue);
}

std::uint64_t ExecutorCore::addTimer(std::chrono::nanoseconds period, std::function<void()> fn) {
  if (period <= 0ns) throw std::invalid_argument("executor timer: the period must be positive");
  std::uint64_t id;
  {
    std::lock_guard lock(mutex_);
    id = next_timer_id_++;
    timers_.emplace(id, Timer{period, Clock::now() + period, std::move(fn)});
  }
  changed_.notify_one();
  return id;
}

void ExecutorCore::cancelTimer(std::uint64_t id) {
  std::lock_guard lock(mutex_);
  timers_.erase(id);
}

std::thread::id ExecutorCore::threadId() const {
  std::lock_guard lock(mutex_);
  return thread_;
}

std::vector<QueueStats> ExecutorCore::queueStats() const {
  std::vector<std::shared_ptr<SampleQueue>> queues;
  {
    std::lock_guard lock(mutex_);
    for (const auto& q : queues_)
      if (auto s = q.lock()) queues.push_back(std::move(s));
  }
  std::vector<QueueStats> out;
  for (const auto& q : queues) out.push_back(q->stats());
  return out;
}

void ExecutorCore::stop() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
}

void ExecutorCore::run() {
  {
    std::lock_guard lock(mutex_);
    thread_ = std::this_thread::get_id();
  }
  running_ = true;
  struct Finally {
    ExecutorCore& core;
    ~Finally() {
      std::lock_guard lock(core.mutex_);
      core.ready_.clear();
      core.thread_ = {};
      core.running_ = false;
    }
  } finally{*this};

  std::unique_lock lock(mutex_);
  bool timer_ran_last = false;
  while (!stop_) {
    // A due timer first, then the oldest sample or posted task — but never two timers in a row while a
    // sample waits: a timer that is always due (the simulator's step, with a 3-D scan of 20-170 ms inside,
    // behind at speed 4) otherwise starved every subscription, and the vehicle stood still on a command
    // timeout while the tracker commanded 5 m/s (gart_terrain_3d, docs/benchmarks/mission.md).
    const auto now = Clock::now();
    auto due = timers_.end();
    for (auto it = timers_.begin(); it != timers_.end(); ++it)
      if (it->second.next <= now && (due == timers_.end() || it->second.next < due->second.next)) due = it;
    if (due != timers_.end() && timer_ran_last && !ready_.empty()) due = timers_.end();
    timer_ran_last = due != timers_.end();
    if (due != timers_.end()) {
      Timer& t = due->second;
      t.next += t.period;
      if (now - t.next > std::max<std::chrono::nanoseconds>(t.period, 500ms)) t.next = now + t.period;  // do not catch up after a stall
      auto fn = t.fn;  // the timer may be cancelled by its own callback
      lock.unlock();
      fn();  // an exception ends run(): see the header
      lock.lock();
      continue;
    }
    if (!ready_.empty()) {
      Ready item = std::move(ready_.front());
      ready_.pop_front();
      lock.unlock();
      if (item.task) {
        item.task();  // an exception ends run()
      } else {
        try {
          item.queue->runOne();
        } catch (const std::exception& e) {
          spdlog::warn("{}: callback failed, sample skipped: {}", item.queue->topic(), e.what());
        }
      }
      item = {};
      lock.lock();
      continue;
    }
    auto next = Clock::time_point::max();
    for (const auto& [id, t] : timers_) next = std::min(next, t.next);
    if (next == Clock::time_point::max())
      changed_.wait(lock);
    else
      changed_.wait_until(lock, next);
  }
}

}  // namespace detail

namespace {

// The process's Workers and the clock they stamp jobs with: read by the runtime's progress probe.
struct WorkRegistry {
  std::mutex mutex;
  std::vector<const Worker*> workers;
  std::map<std::uint64_t, std::int64_t> pending;  // PendingWork id -> its stamp
  std::uint64_t next_pending = 1;
  std::function<std::int64_t()> clock;
};

WorkRegistry& workRegistry() {
  static WorkRegistry registry;
  return registry;
}

std::int64_t workClockNow() {
  auto& r = workRegistry();
  std::lock_guard lock(r.mutex);
  return r.clock ? r.clock() : 0;
}

}  // namespace

void setWorkClock(std::function<std::int64_t()> now) {
  auto& r = workRegistry();
  std::lock_guard lock(r.mutex);
  r.clock = std::move(now);
}

std::optional<std::int64_t> oldestPendingWork() {
  auto& r = workRegistry();
  std::lock_guard lock(r.mutex);
  if (!r.clock) return std::nullopt;
  std::optional<std::int64_t> oldest;
  for (const Worker* w : r.workers)
    if (const auto since = w->pendingSince(); since && *since > 0 && (!oldest || *since < *oldest)) oldest = since;
  for (const auto& [id, stamp] : r.pending)
    if (stamp > 0 && (!oldest || stamp < *oldest)) oldest = stamp;
  return oldest;
}

PendingWork::PendingWork() {
  auto& r = workRegistry();
  std::lock_guard lock(r.mutex);
  if (!r.clock) return;
  id_ = r.next_pending++;
  r.pending.emplace(id_, r.clock());
}

PendingWork::~PendingWork() {
  if (id_ == 0) return;
  auto& r = workRegistry();
  std::lock_guard lock(r.mutex);
  r.pending.erase(id_);
}

Worker::Worker(std::string name) : name_(std::move(name)), thread_([this] { loop(); }) {
  auto& r = workRegistry();
  std::lock_guard lock(r.mutex);
  r.workers.push_back(this);
}

Worker::~Worker() {
  {
    auto& r = workRegistry();
    std::lock_guard lock(r.mutex);
    std::erase(r.workers, this);
  }
  stop();
}

std::optional<std::int64_t> Worker::pendingSince() const {
  std::lock_guard lock(mutex_);
  std::optional<std::int64_t> since;
  if (running_) since = running_->submitted_ns;
  for (const auto& e : queue_)
    if (!since || e->submitted_ns < *since) since = e->submitted_ns;
  return since;
}

void Worker::submit(std::uint64_t key, Job job) {
  const std::int64_t submitted_ns = workClockNow();
  {
    std::lock_guard lock(mutex_);
    if (finished_) throw std::logic_error(name_ + ": submit after stop");
    for (auto& e : queue_)
      if (e->key == key) e->stop.request_stop();
    if (running_ && running_->key == key) running_->stop.request_stop();
    auto entry = std::make_shared<Entry>();
    entry->key = key;
    entry->job = std::move(job);
    entry->submitted_ns = submitted_ns;
    if (stopping_) entry->stop.request_stop();
    queue_.push_back(std::move(entry));
  }
  changed_.notify_one();
}

void Worker::stop() {
  {
    std::lock_guard lock(mutex_);
    if (finished_) return;
    stopping_ = true;
    for (auto& e : queue_) e->stop.request_stop();
    if (running_) running_->stop.request_stop();
    finished_ = true;
  }
  changed_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void Worker::loop() {
  std::unique_lock lock(mutex_);
  for (;;) {
    changed_.wait(lock, [&] { return finished_ || !queue_.empty(); });
    if (queue_.empty()) return;  // finished, and every queued job has run
    running_ = std::move(queue_.front());
    queue_.pop_front();
    auto entry = running_;
    lock.unlock();
    try {
      entry->job(entry->stop.get_token());
    } catch (const std::exception& e) {
      spdlog::error("{}: a job failed: {}", name_, e.what());
    }
    lock.lock();
    running_.reset();
  }
}

}  // namespace ddsnav::runtime
