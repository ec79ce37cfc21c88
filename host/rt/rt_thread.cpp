#include "host/rt/rt_thread.h"

#include <time.h>

#include <algorithm>
#include <climits>
#include <cerrno>
#include <future>
#include <stdexcept>

namespace dca::rt {

namespace {

std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void sleep_until(std::int64_t t) {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(t / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(t % 1'000'000'000);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

// A stop is seen within this long, whatever the tasks' periods.
constexpr std::int64_t kMaxSleep = 50'000'000;

}  // namespace

std::int64_t RtHistogram::quantile(double q) const {
  const std::uint64_t n = count();
  if (n == 0) return 0;
  const auto rank = static_cast<std::uint64_t>(std::clamp(q, 0.0, 1.0) * static_cast<double>(n - 1)) + 1;
  std::uint64_t seen = 0;
  for (int i = 0; i < kBuckets; ++i) {
    seen += buckets_[i].load(std::memory_order_relaxed);
    if (seen >= rank) return std::min(upper(i), max());
  }
  return max();
}

RtSummary RtHistogram::summary() const {
  return {count(), static_cast<double>(quantile(0.5)) / 1e3, static_cast<double>(quantile(0.99)) / 1e3,
          static_cast<double>(quantile(0.999)) / 1e3, static_cast<double>(max()) / 1e3};
}

std::vector<std::pair<std::int64_t, std::uint64_t>> RtHistogram::buckets() const {
  std::vector<std::pair<std::int64_t, std::uint64_t>> out;
  for (int i = 0; i < kBuckets; ++i)
    if (const auto n = buckets_[i].load(std::memory_order_relaxed); n > 0) out.emplace_back(upper(i), n);
  return out;
}

struct RtThread::Task {
  std::string name;
  std::int64_t period = 0;
  std::function<void()> fn;
  std::int64_t next = 0;  // the thread's own
  std::atomic<std::uint64_t> runs{0}, overruns{0}, missed{0};
  RtHistogram wake, exec;

  // Runs once (due at `next`), then moves `next` to the first deadline still ahead: periods that went by are
  // counted as missed, never run in a burst.
  void run_once() {
    const std::int64_t start = now_ns();
    wake.record(start - next);
    fn();
    const std::int64_t end = now_ns();
    exec.record(end - start);
    runs.store(runs.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    std::int64_t n = next + period;
    if (end > n) {
      overruns.store(overruns.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
      const std::int64_t skip = (end - n) / period + 1;
      missed.store(missed.load(std::memory_order_relaxed) + static_cast<std::uint64_t>(skip),
                   std::memory_order_relaxed);
      n += skip * period;
    }
    next = n;
  }
};

RtThread::RtThread(RtConfig config) : config_(std::move(config)) {}

RtThread::~RtThread() { stop(); }

void RtThread::add(std::string name, std::int64_t period_ns, std::function<void()> fn) {
  if (running()) throw std::logic_error("RtThread::add: the thread runs already");
  if (period_ns <= 0) throw std::invalid_argument("RtThread::add: the period must be > 0");
  auto t = std::make_unique<Task>();
  t->name = std::move(name);
  t->period = period_ns;
  t->fn = std::move(fn);
  tasks_.push_back(std::move(t));
}

void RtThread::on_wake(std::function<void()> fn) { on_wake_ = std::move(fn); }

std::string RtThread::start() {
  if (running()) return "";
  stop_.store(false);
  std::promise<std::string> ready;
  auto told = ready.get_future();
  thread_ = std::thread([this, &ready] {
    ready.set_value(warning(config_, setup_thread(config_)));
    run();
  });
  return told.get();
}

void RtThread::stop() {
  if (!running()) return;
  stop_.store(true, std::memory_order_relaxed);
  thread_.join();
}

void RtThread::run() {
  const std::int64_t t0 = now_ns();
  for (auto& t : tasks_) t->next = (t0 / t->period + 1) * t->period;
  while (!stop_.load(std::memory_order_relaxed)) {
    std::int64_t due = INT64_MAX;
    for (const auto& t : tasks_) due = std::min(due, t->next);
    const std::int64_t limit = now_ns() + kMaxSleep;
    sleep_until(std::min(due, limit));
    if (stop_.load(std::memory_order_relaxed)) break;
    if (on_wake_) on_wake_();
    const std::int64_t wake = now_ns();
    for (auto& t : tasks_)
      if (t->next <= wake) t->run_once();
  }
}

std::vector<RtTaskStats> RtThread::stats() const {
  std::vector<RtTaskStats> v;
  v.reserve(tasks_.size());
  for (const auto& t : tasks_)
    v.push_back({t->name, t->period, t->runs.load(std::memory_order_relaxed),
                 t->overruns.load(std::memory_order_relaxed), t->missed.load(std::memory_order_relaxed),
                 t->wake.summary(), t->exec.summary()});
  return v;
}

const RtHistogram& RtThread::wake_histogram(std::size_t i) const { return tasks_.at(i)->wake; }

}  // namespace dca::rt
