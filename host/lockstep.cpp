#include "host/lockstep.h"

#include <sched.h>

#include <algorithm>
#include <cstdio>
#include <limits>
#include <utility>

#include <boost/asio/post.hpp>

#include "host/net/channel.h"

namespace dca {

using wire::Message;
using wire::Value;

// ---------------------------------------------------------------------------------------------------------
// LockstepCore: the subscriber table and the rounds, driven by tick() and the links' answers.

LockstepCore::LockstepCore(LockstepOptions options, LockstepHooks hooks)
    : opts_(std::move(options)), hooks_(std::move(hooks)), period_(std::max<Nanos>(1, opts_.period)) {
  sync_ = std::max<Nanos>(period_, from_seconds(opts_.sync_period));
  sync_ = (sync_ / period_) * period_;  // a multiple of the period, so sync ticks happen
  idle_ = std::max<Nanos>(sync_, (from_seconds(opts_.idle_period) / sync_) * sync_);
  duration_ = opts_.duration >= 0 ? from_seconds(opts_.duration) : -1;
  speed_ = opts_.realtime ? 1.0 : 0.0;
}

void LockstepCore::subscribe(const void* origin, std::string name, std::shared_ptr<ClockLink> link, bool supervisor) {
  for (auto it = subs_.begin(); it != subs_.end();) it = it->second.origin == origin ? subs_.erase(it) : std::next(it);
  Subscriber s;
  s.origin = origin;
  s.name = std::move(name);
  s.link = std::move(link);
  s.supervisor = supervisor;
  if (!supervisor) forget(s.name);
  subs_[next_sub_++] = std::move(s);
  clocked_stale_ = true;
}

void LockstepCore::set_leaves(const void* origin, std::vector<std::string> leaves) {
  for (auto& [id, s] : subs_)
    if (s.origin == origin) hosts(s, leaves);
}

// The leaves node `s` hosts now: one it did not host before is a new instance (a shared node's add, after a
// remove when restarted), whose links start their counts afresh.
void LockstepCore::hosts(Subscriber& s, std::vector<std::string> leaves) {
  for (const auto& l : leaves)
    if (std::find(s.leaves.begin(), s.leaves.end(), l) == s.leaves.end()) {
      forget(l);
      // its outputs count from zero, as a new process's would: the trace says nothing until it writes
      const std::string prefix = l + ".";
      std::erase_if(s.out, [&prefix](const auto& kv) { return kv.first.compare(0, prefix.size(), prefix) == 0; });
    }
  s.leaves = std::move(leaves);
  clocked_stale_ = true;
}

bool LockstepCore::clocked(const std::string& leaf) {
  if (clocked_stale_) {
    clocked_.clear();
    for (const auto& [id, s] : subs_) {
      if (s.supervisor) continue;
      if (s.leaves.empty()) clocked_.insert(s.name);
      else clocked_.insert(s.leaves.begin(), s.leaves.end());
    }
    clocked_stale_ = false;
  }
  return clocked_.count(leaf) != 0;
}

// A leaf (re)started in a new process or instance: the counts of every link into it (its inputs are new) or
// out of it (its outputs count from zero again) are forgotten, here and in what each reader was told, so no
// reader is told to wait for samples of a link that no longer exists. Links are keyed
// "from|out>to|in@set" (host/net/endpoint link_key).
void LockstepCore::forget(const std::string& leaf) {
  auto touches = [&leaf](const std::string& key) {
    const auto gt = key.find('>');
    if (gt == std::string::npos) return false;
    const auto bar = key.find('|', gt);
    return key.compare(0, key.find('|'), leaf) == 0 || key.compare(gt + 1, bar - gt - 1, leaf) == 0;
  };
  writer_gone(leaf);
  auto prune = [&touches](std::map<std::string, std::uint64_t>& m) { std::erase_if(m, [&](const auto& kv) {
    return touches(kv.first); }); };
  sent_.erase(leaf);
  for (auto& [to, links] : sent_) prune(links);
  for (auto& [id, s] : subs_) prune(s.told);
  prune(owner_told_);
}

// The owner's inputs that `leaf` wrote to (its links into the owner), each told its writer is gone.
void LockstepCore::writer_gone(const std::string& leaf) {
  auto it = sent_.find(opts_.owner);
  if (!hooks_.writer_gone || it == sent_.end()) return;
  for (const auto& [key, n] : it->second) {
    const auto bar = key.find('|'), gt = key.find('>');
    if (bar == std::string::npos || gt == std::string::npos || key.compare(0, bar, leaf) != 0) continue;
    const auto in = key.find('|', gt), at = key.find('@', gt);
    if (in != std::string::npos && at != std::string::npos && at > in) hooks_.writer_gone(key.substr(in + 1, at - in - 1));
  }
}

void LockstepCore::counted(const void* origin, std::uint64_t received, std::uint64_t sent) {
  for (auto& [id, s] : subs_)
    if (s.origin == origin && s.supervisor) {
      s.received = received;
      s.events = sent;
    }
}

void LockstepCore::unsubscribe(const void* origin) {
  for (auto it = subs_.begin(); it != subs_.end();) {
    if (it->second.origin != origin) {
      ++it;
      continue;
    }
    if (it->second.supervisor) gone_received_ += it->second.received;
    gone_events_ += it->second.events;
    it = subs_.erase(it);
    clocked_stale_ = true;
  }
}

bool LockstepCore::go() {
  if (running_) return false;
  running_ = true;
  wall0_ = hooks_.wall_now() - paced(now());
  if (!first_go_) first_go_ = hooks_.wall_now();
  schedule();
  return true;
}

// Simulated time `t` as wall time at the current speed (from wall0_).
Nanos LockstepCore::paced(Nanos t) const {
  if (speed_ <= 0) return t;
  const double w = static_cast<double>(t) / speed_;  // (at 0.1x, past 29 years of simulated time: the last ns)
  return w < 9.2e18 ? static_cast<Nanos>(w) : std::numeric_limits<Nanos>::max() / 2;
}

void LockstepCore::set_speed(double speed) {
  speed_ = speed > 0 ? speed : 0;
  // re-anchored: the next tick is due one period (at the new speed) from now, whatever came before
  wall0_ = hooks_.wall_now() - paced(now());
}

void LockstepCore::step(bool to_event) {
  if (to_event) {
    hold_at_barrier_ = barriers_;
  } else {
    hold_at_barrier_.reset();
    hold_at_ = now() + period_;
  }
  go();
}

// Asks for the next tick, unless one is asked for already, time is held or a round is open.
void LockstepCore::schedule() {
  if (scheduled_ || !running_ || waiting_ > 0 || phase_ != Phase::Idle) return;
  scheduled_ = true;
  hooks_.schedule(speed_ > 0 ? std::optional<Nanos>(wall0_ + paced(now() + period_)) : std::nullopt);
}

// The owner's inputs: the samples written to it before this tick, counted by their writers' answers.
std::string LockstepCore::take_owner() {
  if (!hooks_.take) return "";
  Value expect = Value::map();
  auto it = sent_.find(opts_.owner);
  if (it != sent_.end())
    for (const auto& [key, n] : it->second)
      if (auto [t, fresh] = owner_told_.try_emplace(key, n); fresh || t->second != n) {
        t->second = n;
        expect.set(key, n);
      }
  return expect.as_map().empty() ? "" : hooks_.take(expect);
}

// The owner steps to t; the due subscribers (if any) are published to and advanced.
void LockstepCore::tick() {
  scheduled_ = false;
  if (!running_ || waiting_ > 0 || phase_ != Phase::Idle || (hooks_.ready && !hooks_.ready())) return;
  for (;;) {
    const Nanos w0 = hooks_.wall_now();
    const auto late = take_owner();
    take_s_ += to_seconds(hooks_.wall_now() - w0);
    if (!late.empty()) {
      std::fprintf(stderr, "%s: time holds: %s\n", opts_.log_name.c_str(), late.c_str());
      dropped_.push_back("time held at " + std::to_string(to_seconds(now())) + " s: " + late);
      running_ = false;
      if (on_stuck) on_stuck("time cannot go on at " + std::to_string(to_seconds(now())) + " s: " + late);
      return;
    }
    const Nanos s0 = hooks_.wall_now();
    hooks_.step();
    step_s_ += to_seconds(hooks_.wall_now() - s0);
    ++steps_;
    const Nanos t = now();
    const auto due = due_at(t);
    if (!due.empty()) {
      hooks_.publish();
      if (hooks_.sent) add_sent(hooks_.sent());
      if (opts_.trace && hooks_.digests) traced(t, hooks_.digests(), owner_out_);
      hooks_.settle();  // the samples are on their way before anyone is told to tick
    }
    wall_s_ += to_seconds(hooks_.wall_now() - w0);
    if ((duration_ >= 0 && t >= duration_ && !duration_hit_) || (hold_at_ && t >= *hold_at_)) {
      if (hold_at_ && t >= *hold_at_) hold_at_.reset();
      else duration_hit_ = true;
      running_ = false;
    }
    if (!due.empty()) {
      phase_ = Phase::Round;
      round0_ = hooks_.wall_now();
      return advance(due, t);
    }
    // A quiet tick (nobody due: nothing published, nothing written). Unpaced, the next one follows in this
    // handler, up to the next sync tick: the loop's other handlers (a `hold`, a `status`) run at least that
    // often, and a world of 1 ms steps under 10 ms controllers pays one loop pass per control period.
    if (!opts_.inline_quiet || !running_ || speed_ > 0 || (t + period_) % sync_ == 0 || !trace_lines_.empty())
      return after_tick();
  }
}

// Those whose next deadline has come; at a sync tick those that have not answered yet (their deadlines are
// not known: a node just started); at an idle tick every node.
std::vector<std::uint64_t> LockstepCore::due_at(Nanos t) const {
  std::vector<std::uint64_t> due;
  const bool sync_tick = t % sync_ == 0, idle_tick = t % idle_ == 0;
  for (const auto& [id, s] : subs_)
    if (!s.supervisor && (idle_tick || (sync_tick && !s.answered) || (s.next && *s.next <= t))) due.push_back(id);
  return due;
}

// The counts of the links into `s` that moved since it was last told: {key = n}.
Value LockstepCore::expect_for(Subscriber& s) {
  Value expect = Value::map();
  const std::vector<std::string> self{s.name};
  for (const auto& leaf : s.leaves.empty() ? self : s.leaves) {
    auto it = sent_.find(leaf);
    if (it == sent_.end()) continue;
    for (const auto& [key, n] : it->second)
      if (auto [t, fresh] = s.told.try_emplace(key, n); fresh || t->second != n) {
        t->second = n;
        expect.set(key, n);
      }
  }
  return expect;
}

// Sends `advance {t, expect}` to each of `due`; the phase ends with the last answer (the +1 covers links that
// answer before the loop is done).
void LockstepCore::advance(const std::vector<std::uint64_t>& due, Nanos t) {
  waiting_ = static_cast<int>(due.size()) + 1;
  std::weak_ptr<bool> alive = alive_;
  const int spin = spin_window();
  for (const auto id : due) {
    auto it = subs_.find(id);
    if (it == subs_.end()) {
      --waiting_;
      continue;
    }
    Value p = Value::map().set("t", t);
    if (auto e = expect_for(it->second); !e.as_map().empty()) p.set("expect", std::move(e));
    if (hooks_.release) hooks_.release(it->second.leaves.empty() ? std::vector<std::string>{it->second.name} : it->second.leaves);
    if (opts_.trace) p.set("trace", true);
    if (spin > 0) p.set("spin", spin);
    it->second.link->request("advance", std::move(p),
                             [this, alive, id, t](const std::string& error, bool replied, const Value& reply) {
                               if (!alive.expired()) answered(id, t, error, replied, reply);
                             });
  }
  if (spin > 0 && waiting_ > 1 && hooks_.spin) hooks_.spin(spin);
  if (--waiting_ == 0) advanced(t);
}

// How long a node polls for its next advance after answering (and the master for the answers): never while
// paced to the wall clock; else the set window, or (auto) kAutoSpinUs while every process on the clock, this
// one included, can have a CPU of its own. Spinning takes the sleep and the wake-up out of each round (a halted
// idle virtual CPU's wake-up is an exit to the host); with more processes than CPUs the spinners would take
// turns on a CPU instead.
int LockstepCore::spin_window() const {
  if (speed_ > 0 || opts_.spin_us == 0) return 0;
  if (opts_.spin_us > 0) return opts_.spin_us;
  std::size_t nodes = 1;
  for (const auto& [id, s] : subs_) nodes += s.supervisor ? 0 : 1;
  return opts_.cpus > 0 && nodes <= static_cast<std::size_t>(opts_.cpus) ? kAutoSpinUs : 0;
}

void LockstepCore::add_sent(const Value& sent) {
  for (const auto& [to, links] : sent.as_map())
    for (const auto& [key, n] : links.as_map())
      sent_[to.as_string()][key.as_string()] = static_cast<std::uint64_t>(n.as_int(0));
}

// A node's answer: its next deadline, its events, its links' counts (and, tracing, its outputs).
void LockstepCore::took(Subscriber& s, Nanos t, const Value& reply) {
  const auto& n = reply["next"];
  s.next = n.is_nil() ? std::nullopt : std::optional<Nanos>(n.as_int(0));
  s.answered = true;
  const auto ev = static_cast<std::uint64_t>(reply["ev"].as_int(0));
  s.events = ev;
  for (const auto& [leaf, count] : reply["evs"].as_map()) {
    // per leaf, the events of all its processes so far: a restarted leaf's new process counts from zero
    auto& known = node_events_[leaf.as_string()];
    auto& seen = s.evs[leaf.as_string()];
    const auto c = static_cast<std::uint64_t>(count.as_int(0));
    const auto now_n = known + (c >= seen ? c - seen : c);
    seen = c;
    if (opts_.trace && known != now_n)
      trace_lines_.push_back(std::to_string(t) + " E " + leaf.as_string() + " events=" + std::to_string(now_n));
    known = now_n;
  }
  if (const auto* l = reply.find("leaves")) {
    std::vector<std::string> names;
    for (const auto& v : l->as_array()) names.push_back(v.as_string());
    hosts(s, std::move(names));
  }
  add_sent(reply["sent"]);
  if (opts_.trace) traced(t, reply["dig"], s.out);
}

// The trace's lines for one answer: each output whose count moved (count, digest, latest value), each set
// switched and each live parameter changed.
void LockstepCore::traced(Nanos t, const Value& dig, std::map<std::string, std::uint64_t>& out) {
  const std::string at = std::to_string(t);
  for (const auto& o : dig["out"].as_array()) {
    const auto& a = o.as_array();
    if (a.size() < 4) continue;
    auto& last = out[a[0].as_string()];
    const auto count = static_cast<std::uint64_t>(a[1].as_int(0));
    if (count == last) continue;
    last = count;
    trace_lines_.push_back(at + " D " + a[0].as_string() + " n=" + std::to_string(count) + " digest=" +
                           a[2].as_string() + " value=" + a[3].str());
  }
  for (const auto& sw : dig["sw"].as_array()) trace_lines_.push_back(at + " S " + sw.as_string());
  for (const auto& p : dig["par"].as_array()) trace_lines_.push_back(at + " P " + p.as_string());
}

void LockstepCore::answered(std::uint64_t id, Nanos t, const std::string& error, bool replied, const Value& reply) {
  auto it = subs_.find(id);
  if (!error.empty()) {
    const std::string at = std::to_string(to_seconds(t));
    drop(id, replied ? "advance to " + at + " s refused: " + error
                     : "did not answer the advance to " + at + " s (" + error + ")");
  } else if (it != subs_.end()) {
    ++advances_;
    took(it->second, t, reply);
  }
  if (--waiting_ == 0) advanced(t);
}

// Every advance of the phase answered (or none to send): the next step of the tick.
void LockstepCore::advanced(Nanos t) {
  if (phase_ == Phase::Round) {
    const Nanos w = hooks_.wall_now() - round0_;
    rounds_.record(w);
    rounds_s_ += to_seconds(w);
    return round_done(t);
  }
  if (phase_ == Phase::SyncBefore) return wave(t);
  round_done(t);  // after the barrier: a reaction may have caused another event
}

// A node that did not answer counts as lost: an event its supervisor will hear of (its exit).
void LockstepCore::drop(std::uint64_t id, const std::string& why) {
  auto it = subs_.find(id);
  if (it == subs_.end()) return;
  const std::string msg = it->second.name + ": " + why;
  std::fprintf(stderr, "%s: dropped from the clock: %s\n", opts_.log_name.c_str(), msg.c_str());
  dropped_.push_back(msg);
  if (opts_.trace)
    for (const auto& leaf : it->second.leaves.empty() ? std::vector<std::string>{it->second.name} : it->second.leaves)
      trace_lines_.push_back(std::to_string(now()) + " L " + leaf);
  if (it->second.supervisor) {
    gone_received_ += it->second.received;
    supervisor_lost_ = true;
  } else {  // each of its leaves ends: one exit each at their supervisors
    const auto& leaves = it->second.leaves;
    lost_ += leaves.empty() ? 1 : leaves.size();
    for (const auto& l : leaves.empty() ? std::vector<std::string>{it->second.name} : leaves) {
      ++lost_names_[l];
      lost_why_[l] = why;
    }
    for (const auto& l : leaves.empty() ? std::vector<std::string>{it->second.name} : leaves) writer_gone(l);
  }
  gone_events_ += it->second.events;
  // told: a node whose process lives on (it stalled) stops rather than staying frozen at its last tick, so
  // its supervisor hears of its exit (and a restart replaces it)
  auto link = it->second.supervisor ? nullptr : it->second.link;
  subs_.erase(it);
  clocked_stale_ = true;
  if (link) link->close("dropped from the clock: " + msg);
}

// Events sent by everyone (nodes' done/aborted, nodes lost, supervisors' outcomes to their parents).
std::uint64_t LockstepCore::events_sent() const {
  std::uint64_t n = gone_events_ + lost_;
  for (const auto& [id, s] : subs_) n += s.events;
  return n;
}

// The end of a round (or of a barrier's last sync): a barrier if something happened, else the next tick.
void LockstepCore::round_done(Nanos t) {
  bool supervisors = false;
  for (const auto& [id, s] : subs_) supervisors = supervisors || s.supervisor;
  if (!supervisors || events_sent() == settled_) {
    if (phase_ == Phase::SyncAfter) barrier_s_ += to_seconds(hooks_.wall_now() - barrier0_);
    phase_ = Phase::Idle;
    return after_tick();
  }
  if (phase_ == Phase::Round) barrier0_ = hooks_.wall_now();
  ++barriers_;
  last_wave_.clear();
  sync_all(t, Phase::SyncBefore);
}

// Every node advanced to t (nothing new is due: their clocks read t, their counts come in).
void LockstepCore::sync_all(Nanos t, Phase next) {
  phase_ = next;
  std::vector<std::uint64_t> all;
  for (const auto& [id, s] : subs_)
    if (!s.supervisor) all.push_back(id);
  advance(all, t);
}

// One wave of `quiesce {t}` to every supervisor.
void LockstepCore::wave(Nanos t) {
  phase_ = Phase::Waves;
  ++waves_;
  std::vector<std::uint64_t> sups;
  for (const auto& [id, s] : subs_)
    if (s.supervisor) sups.push_back(id);
  waiting_ = static_cast<int>(sups.size()) + 1;
  std::weak_ptr<bool> alive = alive_;
  const Value c = counts();
  const Value q =
      Value::map().set("t", t).set("events", c["events"]).set("lost", c["lost"]).set("why", c["why"]);
  for (const auto id : sups) {
    subs_[id].link->request("quiesce", q,
                            [this, alive, id, t](const std::string& error, bool replied, const Value& reply) {
                              if (alive.expired()) return;
                              if (!error.empty()) {
                                drop(id, replied ? "quiesce refused: " + error : "did not answer quiesce (" + error + ")");
                              } else if (auto it = subs_.find(id); it != subs_.end()) {
                                it->second.received = static_cast<std::uint64_t>(reply["received"].as_int(0));
                                it->second.events = static_cast<std::uint64_t>(reply["sent"].as_int(0));
                              }
                              if (--waiting_ == 0) waved(t);
                            });
  }
  if (--waiting_ == 0) waved(t);
}

// After a wave: settled when every event sent was received and the counts did not move since the last wave.
void LockstepCore::waved(Nanos t) {
  std::vector<std::pair<std::uint64_t, std::uint64_t>> counts;
  std::uint64_t received = gone_received_;
  for (const auto& [id, s] : subs_)
    if (s.supervisor) {
      counts.emplace_back(s.received, s.events);
      received += s.received;
    }
  // Once a supervisor is lost (its host gone), the events meant for it are never received: the barrier then
  // ends on stable counts alone (a lost host is no part of the exact semantics).
  const bool stable = counts == last_wave_ && (received >= events_sent() || supervisor_lost_);
  last_wave_ = std::move(counts);
  if (!stable) return wave(t);
  settled_ = events_sent();
  sync_all(t, Phase::SyncAfter);
}

void LockstepCore::flush_trace() {
  if (trace_lines_.empty()) return;
  std::sort(trace_lines_.begin(), trace_lines_.end());
  if (hooks_.trace) {
    for (const auto& l : trace_lines_) hooks_.trace(l);
    hooks_.trace("");  // the tick's end: written out
  }
  trace_lines_.clear();
}

void LockstepCore::after_tick() {
  hooks_.settle();  // take in what the subscribers wrote at this tick
  flush_trace();
  if (hold_at_barrier_ && barriers_ > *hold_at_barrier_) {  // a step to the next event: this tick had one
    hold_at_barrier_.reset();
    running_ = false;
  }
  if (duration_hit_ && on_duration_pending_) {
    on_duration_pending_ = false;
    if (on_duration) on_duration();
  }
  schedule();
}

Value LockstepCore::counts() const {
  Value events = Value::map(), lost = Value::map(), why = Value::map();
  for (const auto& [name, n] : node_events_) events.set(name, n);
  for (const auto& [name, n] : lost_names_) lost.set(name, n);
  for (const auto& [name, w] : lost_why_) why.set(name, w);
  return Value::map().set("events", events).set("lost", lost).set("why", why);
}

Value LockstepCore::status() const {
  Value names = Value::array(), drops = Value::array();
  for (const auto& [id, sub] : subs_) names.array_ref().push_back(Value(sub.name));
  for (const auto& d : dropped_) drops.array_ref().push_back(Value(d));
  return Value::map()
      .set("now", now())
      .set("t", to_seconds(now()))
      .set("running", running_)
      .set("speed", speed_)
      .set("stepping", hold_at_barrier_.has_value() || hold_at_.has_value())
      .set("steps", static_cast<std::int64_t>(steps_))
      .set("wall_s", wall_s_)
      .set("step_s", step_s_)
      .set("take_s", take_s_)
      .set("rounds_s", rounds_s_)
      .set("barrier_s", barrier_s_)
      .set("run_wall_s", first_go_ ? to_seconds(hooks_.wall_now() - *first_go_) : 0.0)
      .set("subscribers", names)
      .set("dropped", drops)
      .set("rounds", static_cast<std::int64_t>(rounds_.count()))
      .set("advances", static_cast<std::int64_t>(advances_))
      .set("round_p50_us", static_cast<double>(rounds_.quantile(0.5)) / 1000.0)
      .set("round_p99_us", static_cast<double>(rounds_.quantile(0.99)) / 1000.0)
      .set("round_max_us", static_cast<double>(rounds_.max()) / 1000.0)
      .set("settled", phase_ == Phase::Idle)
      .set("barriers", static_cast<std::int64_t>(barriers_))
      .set("waves", static_cast<std::int64_t>(waves_));
}

// ---------------------------------------------------------------------------------------------------------
// Lockstep: the core on a Loop, its links the subscribers' control channels.

namespace {

// A subscriber's control channel: `advance {t}` as a request with the tick timeout.
class ChannelClockLink final : public ClockLink {
 public:
  ChannelClockLink(std::shared_ptr<Channel> ch, int timeout_ms) : ch_(std::move(ch)), timeout_(timeout_ms) {}
  void request(const std::string& type, Value payload, ReplyFn done) override {
    ch_->request({type, 0, std::move(payload)}, timeout_, [done = std::move(done)](Response r) {
      if (!r.ok()) return done(r.error, r.replied(), Value());
      done("", true, r.message.payload);
    });
  }
  void close(const std::string& why) override { ch_->close(why); }

 private:
  std::shared_ptr<Channel> ch_;
  std::chrono::milliseconds timeout_;
};

Nanos steady_now() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// The options with the CPUs this process may run on (auto spin), unless set.
LockstepOptions with_cpus(LockstepOptions o) {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (o.cpus == 0 && ::sched_getaffinity(0, sizeof set, &set) == 0) o.cpus = CPU_COUNT(&set);
  return o;
}

}  // namespace

Lockstep::Lockstep(Loop& loop, LockstepOptions options, LockstepHooks hooks)
    : loop_(loop),
      opts_(options),
      timer_(loop.io()),
      master_timer_(loop.io()),
      core_(with_cpus(std::move(options)), [&] {
        hooks.settle = [this] { loop_.settle(); };
        hooks.spin = [this](int us) { loop_.spin_for(std::chrono::microseconds(us)); };
        hooks.schedule = [this](std::optional<Nanos> wall_due) { schedule(wall_due); };
        hooks.wall_now = steady_now;
        return std::move(hooks);
      }()) {
  core_.on_duration = [this] {
    if (on_duration) on_duration();
  };
  core_.on_stuck = [this](const std::string& why) {
    if (on_stuck) on_stuck(why);
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
  if (core_.speed() > 0 && !core_.running()) minimise_timer_slack();
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
    const bool sup = m.payload["role"].as_string() == "supervisor";
    core_.subscribe(ch.get(), std::move(name), std::make_shared<ChannelClockLink>(ch, opts_.tick_timeout_ms), sup);
    if (sup) return ch->reply(m, core_.counts().set("now", core_.now())), true;
  } else if (m.type == "go") {
    if (master_.expired()) {
      master_ = ch;
      master_peer_ = ch->peer();
      watch_master();
    }
    go();
  } else if (m.type == "unclock") {
    // a supervisor leaving in order (its group stopped, to restart or for good) says its last counts: not lost
    if (m.payload.find("received"))
      core_.counted(ch.get(), static_cast<std::uint64_t>(m.payload["received"].as_int(0)),
                    static_cast<std::uint64_t>(m.payload["sent"].as_int(0)));
    core_.unsubscribe(ch.get());
    if (m.id != 0) ch->reply(m, Value::map());
    return true;
  } else if (m.type == "leaves") {
    std::vector<std::string> names;
    for (const auto& v : m.payload["leaves"].as_array()) names.push_back(v.as_string());
    core_.set_leaves(ch.get(), std::move(names));
    return true;
  } else if (m.type == "hold") {
    if (m.payload.find("at")) core_.hold_at(m.payload["at"].as_int(0));
    else core_.hold();
  } else if (m.type == "pace") {
    const double s = m.payload["speed"].as_float(0);
    if (s != 0 && !(s >= 0.1 && s <= 10)) return ch->reply_error(m, "pace: speed is 0.1 to 10, or 0 (unpaced)"), true;
    if (s > 0) minimise_timer_slack();
    core_.set_speed(s);
    return ch->reply(m, Value::map().set("now", core_.now()).set("speed", core_.speed())), true;
  } else if (m.type == "step") {
    const std::string to = m.payload["to"].is_nil() ? "tick" : m.payload["to"].as_string();
    if (to != "tick" && to != "event") return ch->reply_error(m, "step: to is \"tick\" or \"event\""), true;
    if (core_.speed() > 0) minimise_timer_slack();
    core_.step(to == "event");
  } else if (m.type == "status") {
    return ch->reply(m, core_.status()), true;
  } else {
    return false;
  }
  ch->reply(m, Value::map().set("now", core_.now()));
  return true;
}

}  // namespace dca
