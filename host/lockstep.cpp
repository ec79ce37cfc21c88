#include "host/lockstep.h"

#include <algorithm>
#include <cstdio>
#include <utility>

#include <boost/asio/post.hpp>

#include "host/channel.h"

namespace dca {

using wire::Message;
using wire::Value;

// ---------------------------------------------------------------------------------------------------------
// LockstepCore: the subscriber table and the rounds, driven by tick() and the links' answers.

LockstepCore::LockstepCore(LockstepOptions options, LockstepHooks hooks)
    : opts_(std::move(options)), hooks_(std::move(hooks)), period_(std::max<Nanos>(1, opts_.period)) {
  sync_ = std::max<Nanos>(period_, from_seconds(opts_.sync_period));
  sync_ = (sync_ / period_) * period_;  // a multiple of the period, so sync ticks happen
  duration_ = opts_.duration >= 0 ? from_seconds(opts_.duration) : -1;
}

void LockstepCore::subscribe(const void* origin, std::string name, std::shared_ptr<ClockLink> link) {
  for (auto it = subs_.begin(); it != subs_.end();) it = it->second.origin == origin ? subs_.erase(it) : std::next(it);
  subs_[next_sub_++] = {origin, std::move(name), std::move(link), std::nullopt};
}

bool LockstepCore::go() {
  if (running_) return false;
  running_ = true;
  wall0_ = hooks_.wall_now() - now();
  schedule();
  return true;
}

// Asks for the next tick, unless one is asked for already, time is held or a round is open.
void LockstepCore::schedule() {
  if (scheduled_ || !running_ || waiting_ > 0) return;
  scheduled_ = true;
  hooks_.schedule(opts_.realtime ? std::optional<Nanos>(wall0_ + now() + period_) : std::nullopt);
}

// The owner steps to t; the due subscribers (if any) are published to and advanced.
void LockstepCore::tick() {
  scheduled_ = false;
  if (!running_ || waiting_ > 0 || (hooks_.ready && !hooks_.ready())) return;
  const Nanos w0 = hooks_.wall_now();
  hooks_.step();
  ++steps_;
  const Nanos t = now();
  const auto due = due_at(t);
  if (t % sync_ == 0 || !due.empty()) {
    hooks_.publish();
    hooks_.settle();  // the samples are on their way before anyone is told to tick
  }
  wall_s_ += to_seconds(hooks_.wall_now() - w0);
  if (duration_ >= 0 && t >= duration_ && !duration_hit_) {
    duration_hit_ = true;
    running_ = false;
  }
  if (due.empty()) return after_tick();
  advance(due, t);
}

// Every subscriber at a sync tick, else those whose next deadline has come.
std::vector<std::uint64_t> LockstepCore::due_at(Nanos t) const {
  std::vector<std::uint64_t> due;
  const bool sync_tick = t % sync_ == 0;
  for (const auto& [id, s] : subs_)
    if (sync_tick || (s.next && *s.next <= t)) due.push_back(id);
  return due;
}

// Sends `advance {t}` to each of `due`; the round closes with the last answer (the +1 covers links that
// answer before the loop is done).
void LockstepCore::advance(const std::vector<std::uint64_t>& due, Nanos t) {
  waiting_ = static_cast<int>(due.size()) + 1;
  round0_ = hooks_.wall_now();
  std::weak_ptr<bool> alive = alive_;
  for (const auto id : due) {
    auto it = subs_.find(id);
    if (it == subs_.end()) {
      --waiting_;
      continue;
    }
    it->second.link->advance(t, [this, alive, id, t](const std::string& error, bool replied,
                                                     std::optional<Nanos> next) {
      if (!alive.expired()) answered(id, t, error, replied, next);
    });
  }
  if (--waiting_ == 0) after_tick();
}

void LockstepCore::answered(std::uint64_t id, Nanos t, const std::string& error, bool replied,
                            std::optional<Nanos> next) {
  const std::string at = std::to_string(to_seconds(t));
  if (!error.empty()) {
    drop(id, replied ? "advance to " + at + " s refused: " + error
                     : "did not answer the advance to " + at + " s (" + error + ")");
  } else {
    ++advances_;
    if (auto it = subs_.find(id); it != subs_.end()) it->second.next = next;
  }
  if (--waiting_ == 0) {
    rounds_.record(hooks_.wall_now() - round0_);
    after_tick();
  }
}

void LockstepCore::drop(std::uint64_t id, const std::string& why) {
  auto it = subs_.find(id);
  if (it == subs_.end()) return;
  const std::string msg = it->second.name + ": " + why;
  std::fprintf(stderr, "%s: dropped from the clock: %s\n", opts_.log_name.c_str(), msg.c_str());
  dropped_.push_back(msg);
  subs_.erase(it);
}

void LockstepCore::after_tick() {
  hooks_.settle();  // take in what the subscribers wrote at this tick
  if (duration_hit_ && on_duration_pending_) {
    on_duration_pending_ = false;
    if (on_duration) on_duration();
  }
  schedule();
}

Value LockstepCore::status() const {
  Value names = Value::array(), drops = Value::array();
  for (const auto& [id, sub] : subs_) names.array_ref().push_back(Value(sub.name));
  for (const auto& d : dropped_) drops.array_ref().push_back(Value(d));
  return Value::map()
      .set("now", now())
      .set("t", to_seconds(now()))
      .set("running", running_)
      .set("steps", static_cast<std::int64_t>(steps_))
      .set("wall_s", wall_s_)
      .set("subscribers", names)
      .set("dropped", drops)
      .set("rounds", static_cast<std::int64_t>(rounds_.count()))
      .set("advances", static_cast<std::int64_t>(advances_))
      .set("round_p50_us", static_cast<double>(rounds_.quantile(0.5)) / 1000.0)
      .set("round_p99_us", static_cast<double>(rounds_.quantile(0.99)) / 1000.0)
      .set("round_max_us", static_cast<double>(rounds_.max()) / 1000.0);
}

// ---------------------------------------------------------------------------------------------------------
// Lockstep: the core on a Loop, its links the subscribers' control channels.

namespace {

// A subscriber's control channel: `advance {t}` as a request with the tick timeout.
class ChannelClockLink final : public ClockLink {
 public:
  ChannelClockLink(std::shared_ptr<Channel> ch, int timeout_ms) : ch_(std::move(ch)), timeout_(timeout_ms) {}
  void advance(Nanos t, AdvanceFn done) override {
    ch_->request({"advance", 0, Value::map().set("t", t)}, timeout_, [done = std::move(done)](Response r) {
      if (!r.ok()) return done(r.error, r.replied(), std::nullopt);
      const auto& n = r.message.payload["next"];
      done("", true, n.is_nil() ? std::nullopt : std::optional<Nanos>(n.as_int(0)));
    });
  }

 private:
  std::shared_ptr<Channel> ch_;
  std::chrono::milliseconds timeout_;
};

Nanos steady_now() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

Lockstep::Lockstep(Loop& loop, LockstepOptions options, LockstepHooks hooks)
    : loop_(loop), opts_(options), timer_(loop.io()), master_timer_(loop.io()), core_(std::move(options), [&] {
        hooks.settle = [this] { loop_.settle(); };
        hooks.schedule = [this](std::optional<Nanos> wall_due) { schedule(wall_due); };
        hooks.wall_now = steady_now;
        return std::move(hooks);
      }()) {
  core_.on_duration = [this] {
    if (on_duration) on_duration();
  };
}

// The core's next tick: posted, or (paced to the wall clock) on the timer.
void Lockstep::schedule(std::optional<Nanos> wall_due) {
  std::weak_ptr<bool> alive = alive_;
  if (!wall_due) {
    boost::asio::post(loop_.io(), [this, alive] {
      if (!alive.expired()) core_.tick();
    });
    return;
  }
  timer_.expires_at(std::chrono::steady_clock::time_point(
      std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::nanoseconds(*wall_due))));
  timer_.async_wait([this, alive](const boost::system::error_code& ec) {
    if (!ec && !alive.expired()) core_.tick();
  });
}

void Lockstep::go() {
  // paced to the wall clock: its ticks wake on time (1 ns timer slack, as dca's wall-clock timers have,
  // instead of the default 50 µs that would add to every control period of the nodes on its clock)
  if (opts_.realtime && !core_.running()) minimise_timer_slack();
  core_.go();
}

// Every 100 ms: has the master's channel closed? Then time holds and the owner is told (once).
void Lockstep::watch_master() {
  master_timer_.expires_after(std::chrono::milliseconds(100));
  master_timer_.async_wait([this, alive = std::weak_ptr<bool>(alive_)](const boost::system::error_code& ec) {
    if (ec || alive.expired()) return;
    const auto m = master_.lock();
    if (m && m->is_open()) return watch_master();
    core_.hold();
    if (on_master_lost) on_master_lost("the channel that ran time (" + master_peer_ + ") closed");
  });
}

bool Lockstep::handle(const std::shared_ptr<Channel>& ch, const Message& m) {
  if (m.type == "clock") {
    std::string name = m.payload["name"].as_string();
    if (name.empty()) return ch->reply_error(m, "clock needs the subscriber's name"), true;
    core_.subscribe(ch.get(), std::move(name), std::make_shared<ChannelClockLink>(ch, opts_.tick_timeout_ms));
  } else if (m.type == "go") {
    if (master_.expired()) {
      master_ = ch;
      master_peer_ = ch->peer();
      watch_master();
    }
    go();
  } else if (m.type == "hold") {
    core_.hold();
  } else if (m.type == "status") {
    return ch->reply(m, core_.status()), true;
  } else {
    return false;
  }
  ch->reply(m, Value::map().set("now", core_.now()));
  return true;
}

}  // namespace dca
