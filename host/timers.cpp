#include "host/timers.h"

#include <sys/prctl.h>
#include <sys/timerfd.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <stdexcept>
#include <system_error>

namespace asio = boost::asio;

namespace dca {

Nanos from_seconds(double s) {
  if (std::isnan(s)) return 0;
  const double ns = s * 1e9;
  if (ns >= 9.2e18) return kNever;  // llround would overflow past 2^63 ns
  if (ns <= -9.2e18) return -kNever;
  return static_cast<Nanos>(std::llround(ns));
}

namespace {
// t + d for t, d >= 0, saturating at kNever.
Nanos later(Nanos t, Nanos d) { return d >= kNever - t ? kNever : t + d; }
}  // namespace
double to_seconds(Nanos n) { return static_cast<double>(n) * 1e-9; }

Nanos monotonic_now() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<Nanos>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

bool minimise_timer_slack() { return ::prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL) == 0; }

const char* to_string(ClockKind k) { return k == ClockKind::Wall ? "wall" : "sim"; }

void LatenessHistogram::record(Nanos late) {
  if (late < 0) late = 0;
  ++count_;
  max_ = std::max(max_, late);
  const Nanos us = late / 1000;
  std::size_t b;
  if (us < kFine) b = static_cast<std::size_t>(us);
  else if (us < kFine + Nanos{kCoarse} * 100) b = static_cast<std::size_t>(kFine + (us - kFine) / 100);
  else b = kFine + kCoarse;
  ++buckets_[b];
}

Nanos LatenessHistogram::quantile(double q) const {
  if (count_ == 0) return 0;
  const auto want = static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(count_)));
  std::uint64_t seen = 0;
  for (std::size_t b = 0; b <= kFine + kCoarse; ++b) {
    seen += buckets_[b];
    if (seen >= std::max<std::uint64_t>(want, 1)) {
      Nanos upper;
      if (b < kFine) upper = static_cast<Nanos>(b + 1) * 1000;
      else if (b < kFine + kCoarse) upper = (kFine + static_cast<Nanos>(b - kFine + 1) * 100) * 1000;
      else upper = max_;
      return std::min(upper, max_);
    }
  }
  return max_;
}

std::size_t IntervalHistogram::index(Nanos v) {
  const auto u = static_cast<std::uint64_t>(v);
  if (u < 2 * kSub) return static_cast<std::size_t>(u);
  if (u >> kTopBit) return kBuckets - 1;
  const int g = std::bit_width(u) - 1 - kSubBits;  // >= 1
  return static_cast<std::size_t>(kSub) * static_cast<std::size_t>(g) + static_cast<std::size_t>(u >> g);
}

Nanos IntervalHistogram::upper(std::size_t i) {
  if (i < 2 * kSub) return static_cast<Nanos>(i);
  const std::size_t g = i / kSub - 1, sub = i - kSub * g;
  return static_cast<Nanos>(((sub + 1) << g) - 1);
}

void IntervalHistogram::record(Nanos v) {
  if (v < 0) v = 0;
  min_ = count_ ? std::min(min_, v) : v;
  max_ = std::max(max_, v);
  ++count_;
  sum_ += static_cast<double>(v);
  ++buckets_[index(v)];
}

void IntervalHistogram::merge(const IntervalHistogram& o) {
  if (!o.count_) return;
  min_ = count_ ? std::min(min_, o.min_) : o.min_;
  max_ = std::max(max_, o.max_);
  count_ += o.count_;
  sum_ += o.sum_;
  for (int i = 0; i < kBuckets; ++i) buckets_[i] += o.buckets_[i];
}

Nanos IntervalHistogram::quantile(double q) const {
  if (count_ == 0) return 0;
  const auto want = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(count_))));
  std::uint64_t seen = 0;
  for (int b = 0; b < kBuckets; ++b) {
    seen += buckets_[b];
    if (seen >= want) return b == kBuckets - 1 ? max_ : std::clamp(upper(static_cast<std::size_t>(b)), min_, max_);
  }
  return max_;
}

IntervalSummary summarize(const IntervalHistogram& h) {
  IntervalSummary s;
  s.n = h.count();
  s.p50_us = static_cast<double>(h.quantile(0.5)) / 1000.0;
  s.p99_us = static_cast<double>(h.quantile(0.99)) / 1000.0;
  s.p999_us = static_cast<double>(h.quantile(0.999)) / 1000.0;
  s.max_us = static_cast<double>(h.max()) / 1000.0;
  s.min_us = static_cast<double>(h.min()) / 1000.0;
  s.mean_us = h.mean() / 1000.0;
  return s;
}

namespace {
// The intervals of the periodic timers of one (name, period) (see timers.h).
struct Intervals {
  std::string name;
  Nanos period = 0;
  IntervalHistogram clock, wall;
};

struct Entry {
  TimerServer::Id id = 0;
  std::string name;
  Nanos deadline = 0;
  Nanos period = 0;
  std::function<void()> fn;
  bool active = true;
  std::uint64_t missed = 0;
  LatenessHistogram hist;
  Intervals* intervals = nullptr;     // periodic timers: where their intervals go (nullptr: not measured)
  Nanos last_clock = -1, last_wall = -1;  // when the previous callback ran
};

constexpr std::size_t kKeepFinished = 256;
}  // namespace

struct TimerServer::Impl {
  Impl(asio::io_context& io, ClockKind kind) : fd(io) {
    if (kind == ClockKind::Wall) {
      const int f = ::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
      if (f < 0) throw std::system_error(errno, std::generic_category(), "timerfd_create");
      fd.assign(f);
      minimise_timer_slack();
    }
  }
  asio::posix::stream_descriptor fd;
  std::vector<std::unique_ptr<Entry>> entries;  // stable addresses: callbacks may add timers
  std::vector<std::unique_ptr<Intervals>> intervals;  // per (name, period), at most kMaxIntervalKeys
  Id next_id = 1;
  Nanos sim_now = 0;
  Nanos armed = -1;  // the deadline the timerfd is set for (-1: disarmed)
  bool driven = false;  // set_driven: a thread of the owner's calls run_due(), the timerfd stays disarmed
  bool waiting = false;
  int firing = 0;    // > 0 while callbacks run: no cleanup then
  Nanos current = -1;  // the deadline of the callback running now
  std::shared_ptr<bool> alive = std::make_shared<bool>(true);

  // The active timers by (deadline, id), a binary min-heap with lazy removal: an item whose entry was cancelled
  // or has moved on to a later deadline is dropped when it reaches the top. A round costs O(log n) per timer it
  // fires, not a scan of every timer per fire (1,000 leaves in one node: the scan was 24 % of its CPU).
  struct Due {
    Nanos deadline;
    Id id;
    Entry* entry;
  };
  static bool later_first(const Due& a, const Due& b) {  // std::*_heap keep the largest first: invert
    return a.deadline != b.deadline ? a.deadline > b.deadline : a.id > b.id;
  }
  mutable std::vector<Due> heap;
  void push(Entry& e) {
    heap.push_back({e.deadline, e.id, &e});
    std::push_heap(heap.begin(), heap.end(), later_first);
  }
  // The top item, stale ones dropped first; nullptr when no timer is active.
  const Due* top() const {
    while (!heap.empty()) {
      const Due& d = heap.front();
      if (d.entry->active && d.entry->deadline == d.deadline) return &d;
      std::pop_heap(heap.begin(), heap.end(), later_first);
      heap.pop_back();
    }
    return nullptr;
  }
  // The timer to run next if it is due by `t`: the earliest deadline, ties in creation order (by id).
  Entry* due(Nanos t) {
    const Due* d = top();
    return d && d->deadline <= t ? d->entry : nullptr;
  }
  std::optional<Nanos> next() const {
    const Due* d = top();
    return d ? std::optional<Nanos>(d->deadline) : std::nullopt;
  }
  void cleanup() {
    if (firing) return;
    std::size_t finished = 0;
    for (const auto& e : entries) finished += !e->active;
    if (finished <= kKeepFinished) return;
    std::size_t drop = finished - kKeepFinished;
    std::erase_if(entries, [&](const std::unique_ptr<Entry>& e) {
      if (drop && !e->active) {
        --drop;
        return true;
      }
      return false;
    });
    // items of erased entries would dangle: the heap again from the active ones
    heap.clear();
    for (const auto& e : entries)
      if (e->active) push(*e);
  }
  Intervals* intervals_for(const std::string& name, Nanos period) {
    for (auto& i : intervals)
      if (i->period == period && i->name == name) return i.get();
    if (intervals.size() >= kMaxIntervalKeys) return nullptr;
    intervals.push_back(std::make_unique<Intervals>());
    intervals.back()->name = name;
    intervals.back()->period = period;
    return intervals.back().get();
  }
  // Runs one due entry; `now` is the time it runs at on the server's clock, `wall` on the wall clock.
  void fire(Entry& e, Nanos now, Nanos wall, TimerServer& ts) {
    e.hist.record(now - e.deadline);
    if (e.intervals) {
      if (e.last_clock >= 0) {
        e.intervals->clock.record(now - e.last_clock);
        e.intervals->wall.record(wall - e.last_wall);
      }
      e.last_clock = now;
      e.last_wall = wall;
    }
    const Nanos deadline = e.deadline;
    if (e.period > 0) {
      e.deadline = later(e.deadline, e.period);
      if (e.deadline != kNever && e.deadline <= now) {  // overran whole periods: skip them, count them
        const Nanos k = (now - e.deadline) / e.period + 1;
        e.deadline += k * e.period;
        e.missed += static_cast<std::uint64_t>(k);
      }
      push(e);
    } else {
      e.active = false;
    }
    ++firing;
    const Nanos outer = current;
    current = deadline;
    // Keep the callable alive even if the callback cancels its own timer.
    auto fn = e.period > 0 ? nullptr : std::move(e.fn);
    if (ts.on_enter) ts.on_enter(&e.name);
    if (fn) fn();
    else e.fn();
    if (ts.on_enter) ts.on_enter(nullptr);
    if (ts.on_ran) ts.on_ran(e.name, deadline, e.period, wall, monotonic_now());
    current = outer;
    --firing;
    if (ts.on_fire) ts.on_fire(e.name, deadline);
  }
  void arm(TimerServer& ts);
  void on_ready(TimerServer& ts);
};

void TimerServer::Impl::arm(TimerServer& ts) {
  if (driven) return;
  const auto n = next();
  const Nanos want = n && *n != kNever ? *n : -1;  // due never: nothing to arm
  if (want != armed) {
    itimerspec its{};
    if (want >= 0) {
      its.it_value.tv_sec = want / 1'000'000'000;
      its.it_value.tv_nsec = want % 1'000'000'000;
      if (its.it_value.tv_sec == 0 && its.it_value.tv_nsec == 0) its.it_value.tv_nsec = 1;
    }
    ::timerfd_settime(fd.native_handle(), TFD_TIMER_ABSTIME, &its, nullptr);
    armed = want;
  }
  if (want >= 0 && !waiting) {
    waiting = true;
    fd.async_wait(asio::posix::stream_descriptor::wait_read,
                  [this, &ts, alive = alive](const boost::system::error_code& ec) {
                    if (!*alive) return;
                    waiting = false;
                    if (ec) return;
                    on_ready(ts);
                  });
  }
}

void TimerServer::Impl::on_ready(TimerServer& ts) {
  std::uint64_t expirations = 0;
  [[maybe_unused]] const auto r = ::read(fd.native_handle(), &expirations, sizeof expirations);
  armed = -1;  // a fired ABSTIME timerfd is disarmed
  for (;;) {
    const Nanos now = monotonic_now();
    Entry* e = due(now);
    if (!e) break;
    fire(*e, now, now, ts);
  }
  cleanup();
  arm(ts);
}

TimerServer::TimerServer(asio::io_context& io, ClockKind kind)
    : kind_(kind), impl_(std::make_unique<Impl>(io, kind)) {}

TimerServer::~TimerServer() {
  *impl_->alive = false;
  boost::system::error_code ec;
  impl_->fd.close(ec);
}

TimerServer::Id TimerServer::every(Nanos period, std::function<void()> fn, std::string name, Nanos first) {
  if (period <= 0) throw std::invalid_argument("timer '" + name + "': period must be positive");
  auto e = std::make_unique<Entry>();
  e->id = impl_->next_id++;
  e->name = std::move(name);
  e->period = period;
  const Nanos t = now();
  e->deadline = first >= 0 ? first : aligned_ ? later(t / period * period, period) : later(t, period);
  e->fn = std::move(fn);
  e->intervals = impl_->intervals_for(e->name, period);
  const Id id = e->id;
  impl_->push(*e);
  impl_->entries.push_back(std::move(e));
  if (kind_ == ClockKind::Wall && !impl_->firing) impl_->arm(*this);
  return id;
}

TimerServer::Id TimerServer::after(Nanos delay, std::function<void()> fn, std::string name) {
  auto e = std::make_unique<Entry>();
  e->id = impl_->next_id++;
  e->name = std::move(name);
  e->deadline = later(now(), std::max<Nanos>(delay, 0));
  e->fn = std::move(fn);
  const Id id = e->id;
  impl_->push(*e);
  impl_->entries.push_back(std::move(e));
  if (kind_ == ClockKind::Wall && !impl_->firing) impl_->arm(*this);
  return id;
}

bool TimerServer::cancel(Id id) {
  for (auto& e : impl_->entries)
    if (e->id == id && e->active) {
      e->active = false;
      if (!impl_->firing) {
        e->fn = nullptr;
        impl_->cleanup();
        if (kind_ == ClockKind::Wall) impl_->arm(*this);
      }
      return true;
    }
  return false;
}

Nanos TimerServer::current_deadline() const { return impl_->current; }

void TimerServer::set_driven() {
  if (kind_ != ClockKind::Wall) throw std::logic_error("set_driven: a simulated clock is advanced, not driven");
  impl_->driven = true;
  itimerspec off{};
  ::timerfd_settime(impl_->fd.native_handle(), TFD_TIMER_ABSTIME, &off, nullptr);
  impl_->armed = -1;
}

// Each entry due at the call runs once: a callback that overruns its period leaves its next deadline behind the
// clock, and reading the clock again here would run it again at once, for ever. The caller's next wake finds it
// late, and fire() skips and counts the periods it missed.
std::size_t TimerServer::run_due() {
  std::size_t n = 0;
  const Nanos now = monotonic_now();
  for (;;) {
    Entry* e = impl_->due(now);
    if (!e) break;
    impl_->fire(*e, now, now, *this);
    ++n;
  }
  impl_->cleanup();
  return n;
}

Nanos TimerServer::now() const { return kind_ == ClockKind::Wall ? monotonic_now() : impl_->sim_now; }

namespace {
TimerStats stats_of(const Entry& e) {
  TimerStats s;
  s.id = e.id;
  s.name = e.name;
  s.period = e.period;
  s.active = e.active;
  s.count = e.hist.count();
  s.missed = e.missed;
  s.p50_us = static_cast<double>(e.hist.quantile(0.5)) / 1000.0;
  s.p99_us = static_cast<double>(e.hist.quantile(0.99)) / 1000.0;
  s.max_us = static_cast<double>(e.hist.max()) / 1000.0;
  return s;
}
}  // namespace

std::vector<TimerStats> TimerServer::stats() const {
  std::vector<TimerStats> v;
  for (const auto& e : impl_->entries) v.push_back(stats_of(*e));
  return v;
}

std::optional<TimerStats> TimerServer::stats(Id id) const {
  for (const auto& e : impl_->entries)
    if (e->id == id) return stats_of(*e);
  return std::nullopt;
}

std::vector<IntervalStats> TimerServer::interval_stats() const {
  std::vector<IntervalStats> v;
  for (const auto& i : impl_->intervals) v.push_back({i->name, i->period, summarize(i->clock), summarize(i->wall)});
  return v;
}

std::optional<Nanos> TimerServer::next_deadline() const { return impl_->next(); }

std::size_t TimerServer::advance_to(Nanos t) {
  if (kind_ != ClockKind::Simulated) throw std::logic_error("advance_to: this TimerServer runs on the wall clock");
  if (t < impl_->sim_now)
    throw std::logic_error("advance_to: time " + std::to_string(t) + " ns is before now (" +
                           std::to_string(impl_->sim_now) + " ns)");
  std::size_t n = 0;
  while (Entry* e = impl_->due(t)) {
    impl_->sim_now = e->deadline;
    impl_->fire(*e, e->deadline, monotonic_now(), *this);
    ++n;
  }
  impl_->sim_now = t;
  impl_->cleanup();
  return n;
}

std::size_t TimerServer::step() {
  const auto n = next_deadline();
  return n ? advance_to(*n) : 0;
}

}  // namespace dca
