#include "host/node_rt.h"

#include <sys/eventfd.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <future>
#include <map>
#include <stdexcept>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

#include "host/rt/spsc_ring.h"

namespace dca {

namespace asio = boost::asio;

namespace {

// A sample between a port and its mirror (pulled: a pull connection's answer, for Input::deliver_pulled).
struct Sample {
  std::uint16_t slot = 0, port = 0;
  std::uint32_t size = 0;
  bool pulled = false;
  std::byte data[RtHost::kMaxSample];
};

// A leaf's input asking its pull connections (Input::request on the thread), for the mirror's on the I/O thread.
struct Pull {
  std::uint16_t slot = 0, port = 0;
};

// A life-cycle operation for the thread; its strings live in the I/O thread's pending entry until the answer.
struct Command {
  std::uint64_t seq = 0;
  RtHost::Op op = RtHost::Op::Halt;
  std::uint16_t slot = 0;
  const std::string* a = nullptr;
  const std::string* b = nullptr;
  std::string* error = nullptr;
};

struct Answer {
  std::uint64_t seq = 0;
  bool ok = false;
};

struct Event {
  std::uint16_t slot = 0;
  ComponentEvent* event = nullptr;  // made on the thread, deleted on the I/O thread
};

void sleep_until(Nanos t) {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(t / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(t % 1'000'000'000);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

template <class T>
void add(std::atomic<T>& a, T n) {
  a.store(a.load(std::memory_order_relaxed) + n, std::memory_order_relaxed);
}

}  // namespace

// One adopted leaf.
struct RtSlot;

// A link from a leaf's output (on the thread) to its mirror (on the I/O thread).
struct RingLink final : Link {
  RingLink(RtHost::Impl* h, std::uint16_t s, std::uint16_t p) : host(h), slot(s), port(p) {}
  RtHost::Impl* host;
  std::uint16_t slot, port;
  void on_write(Bytes b) override;
  void close() override {}
};

// An in-process link between two leaves on the thread (RtHost::link).
struct RouteLink final : Link {
  std::uint16_t from = 0, to = 0;
  Output* out = nullptr;
  Input* in = nullptr;
  RtHost::LinkInfo info;  // names and set (the counters below are the live ones)
  std::atomic<bool> active{false};
  std::atomic<std::uint64_t> sent{0}, skipped{0};
  void on_write(Bytes b) override {
    if (!active.load(std::memory_order_relaxed)) return add(skipped, std::uint64_t{1});
    add(sent, std::uint64_t{1});
    in->deliver(b);
  }
  void close() override {}
};

// The pull source of a leaf's input: its request goes to the mirror's pull connections.
struct RingPull final : PullSource {
  RingPull(RtHost::Impl* h, std::uint16_t s, std::uint16_t p) : host(h), slot(s), port(p) {}
  RtHost::Impl* host;
  std::uint16_t slot, port;
  void request() override;
};

struct RtSlot {
  Component* c = nullptr;
  std::unique_ptr<PortSet> mirror;
  std::vector<std::unique_ptr<RingLink>> links;  // one per output of c
  std::vector<std::unique_ptr<RingPull>> pulls;  // one per input of c
  std::function<void(const ComponentEvent&)> on_event;
  rt::RtHistogram wake, exec;
  std::atomic<std::uint64_t> runs{0}, overruns{0}, missed{0};
  std::atomic<Nanos> period{0};
  ComponentEvent* unsent = nullptr;  // the thread's: an end of run the events ring had no room for, sent later
};

struct RtHost::Impl {
  Impl(asio::io_context& io, rt::RtConfig c) : config(std::move(c)), timers(io, ClockKind::Wall), efd(io) {
    timers.set_driven();
    const int fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    if (fd < 0) throw std::system_error(errno, std::generic_category(), "eventfd");
    efd.assign(fd);
  }
  rt::RtConfig config;
  TimerServer timers;
  asio::posix::stream_descriptor efd;  // the thread tells the I/O thread that its rings hold something
  std::vector<std::unique_ptr<RtSlot>> slots;  // changed only while the thread is stopped; nullptr: forgotten
  std::vector<std::unique_ptr<RouteLink>> routes;  // the same
  rt::SpscRing<Sample, 64> in;                  // I/O -> thread: samples for the leaves' inputs
  rt::SpscRing<Sample, 128> out;                // thread -> I/O: samples the leaves wrote
  static constexpr std::size_t kAnswers = 16;
  rt::SpscRing<Command, 16> commands;
  rt::SpscRing<Answer, kAnswers> answers;
  rt::SpscRing<Event, 16> events;
  rt::SpscRing<Pull, 64> pulls;                 // thread -> I/O: inputs asking their pull connections
  struct Pending {
    std::string a, b, error;
    Reply done;
  };
  std::map<std::uint64_t, std::unique_ptr<Pending>> pending;  // the I/O thread's
  std::uint64_t seq = 0;
  std::atomic<bool> stop{false};
  std::thread thread;
  std::atomic<long> tid{0};
  bool started_once = false;
  bool pushed = false;  // the thread's: something went to the I/O thread since the last notify
  bool waiting = false;
  std::atomic<std::uint64_t> dropped{0};
  std::atomic<std::uint64_t> allocations{0}, locks{0}, faults{0};
  std::shared_ptr<bool> alive = std::make_shared<bool>(true);

  void run();
  void take_commands();
  void take_samples();
  void publish_counts();
  void on_ran(const std::string& name, Nanos deadline, Nanos period, Nanos start, Nanos end);
  void send_unsent() {
    for (auto& s : slots)
      if (s && s->unsent && events.push({static_cast<std::uint16_t>(&s - slots.data()), s->unsent})) {
        s->unsent = nullptr;
        pushed = true;
      }
  }
  void notify() {
    if (!pushed) return;
    pushed = false;
    const std::uint64_t one = 1;
    [[maybe_unused]] const auto n = ::write(efd.native_handle(), &one, sizeof one);
  }
  void wait();
  void drain();
  static bool to_sample(std::uint16_t slot, std::uint16_t port, Bytes b, Sample& s, bool pulled = false) {
    if (b.size() > kMaxSample) return false;
    s.slot = slot;
    s.port = port;
    s.pulled = pulled;
    s.size = static_cast<std::uint32_t>(b.size());
    std::memcpy(s.data, b.data(), b.size());
    return true;
  }
  void push_out(std::uint16_t slot, std::uint16_t port, Bytes b) {
    Sample s;
    if (!to_sample(slot, port, b, s) || !out.push(s)) return add(dropped, std::uint64_t{1});
    pushed = true;
  }
  RtSlot* slot_of(const Component& c) const {
    for (const auto& s : slots)
      if (s && s->c == &c) return s.get();
    return nullptr;
  }
  std::uint16_t index_of(const Component& c) const {
    for (std::size_t i = 0; i < slots.size(); ++i)
      if (slots[i] && slots[i]->c == &c) return static_cast<std::uint16_t>(i);
    return 0xffff;
  }
};

void RingLink::on_write(Bytes b) { host->push_out(slot, port, b); }

void RingPull::request() {
  if (!host->pulls.push({slot, port})) return add(host->dropped, std::uint64_t{1});
  host->pushed = true;
}

RtHost::RtHost(asio::io_context& io, rt::RtConfig config) : impl_(std::make_unique<Impl>(io, std::move(config))) {
  impl_->timers.on_ran = [this](const std::string& name, Nanos deadline, Nanos period, Nanos start, Nanos end) {
    impl_->on_ran(name, deadline, period, start, end);
  };
}

RtHost::~RtHost() {
  stop();
  *impl_->alive = false;
  boost::system::error_code ec;
  impl_->efd.close(ec);
  for (Event e; impl_->events.pop(e);) delete e.event;
  for (auto& slot : impl_->slots)
    if (slot) delete std::exchange(slot->unsent, nullptr);
  // (a leaf's component may be gone by now: its outputs closed our links, which own nothing)
}

TimerServer& RtHost::timers() { return impl_->timers; }
bool RtHost::running() const { return impl_->thread.joinable(); }
long RtHost::thread_id() const { return impl_->tid.load(); }
std::uint64_t RtHost::dropped() const { return impl_->dropped.load(std::memory_order_relaxed); }

rt::contract::Counts RtHost::contract() const {
  return {impl_->allocations.load(), impl_->locks.load(), impl_->faults.load()};
}

// The mirror: the same ports; what is delivered to an input goes to the ring at once (its queue drained).
PortSet& RtHost::adopt(Component& c, std::function<void(const ComponentEvent&)> on_event) {
  auto& I = *impl_;
  // (a slot is never used again: a sample on its way to a forgotten leaf must not reach a new one)
  if (I.slots.size() >= 0xffff) throw std::length_error("RtHost: 65535 leaves adopted in this process");
  const bool was = running();
  stop();
  auto s = std::make_unique<RtSlot>();
  s->c = &c;
  s->on_event = std::move(on_event);
  s->mirror = std::make_unique<PortSet>();
  const auto slot = static_cast<std::uint16_t>(I.slots.size());
  const auto& ins = c.ports().inputs();
  for (std::size_t p = 0; p < ins.size(); ++p) {
    ins[p]->reserve_queue(16);  // a push connection's default queue (docs/data-plane.md)
    Input& m = s->mirror->add_input(ins[p]->spec());
    m.on_sample = [this, &I, &m, in = &*ins[p], slot, port = static_cast<std::uint16_t>(p)] {
      // a push connection asked for a longer queue than the leaf's input has (its connect's queue, over 16):
      // the input grows to it with the thread paused, at the first sample, so the thread never allocates
      if (m.capacity() > in->capacity()) {
        const bool going = running();
        stop();
        in->reserve_queue(m.capacity());
        if (going) start();
      }
      Sample x;
      bool queued = false;
      while (m.pop()) {
        queued = true;
        if (!Impl::to_sample(slot, port, m.current_bytes(), x) || !I.in.push(x)) add(I.dropped, std::uint64_t{1});
      }
      if (!queued && m.has_current() &&  // nothing queued: a pull connection's answer, made current
          (!Impl::to_sample(slot, port, m.current_bytes(), x, true) || !I.in.push(x)))
        add(I.dropped, std::uint64_t{1});
    };
    s->pulls.push_back(std::make_unique<RingPull>(&I, slot, static_cast<std::uint16_t>(p)));
    ins[p]->add_pull_source(s->pulls.back().get());
  }
  const auto& outs = c.ports().outputs();
  for (std::size_t p = 0; p < outs.size(); ++p) {
    s->mirror->add_output(outs[p]->spec());
    s->links.push_back(std::make_unique<RingLink>(&I, slot, static_cast<std::uint16_t>(p)));
    outs[p]->attach(s->links.back().get());
  }
  c.on_event = [&I, slot](const ComponentEvent& e) {
    auto* ev = new ComponentEvent(e);
    RtSlot& me = *I.slots[slot];
    // more ends of runs than the ring holds before the I/O thread drains it (a shared node of many leaves):
    // kept and sent at the next wake (a leaf's run ends once; a second end replaces the first)
    if (!I.events.push({slot, ev})) return delete me.unsent, void(me.unsent = ev);
    I.pushed = true;
  };
  PortSet& mirror = *s->mirror;
  I.slots.push_back(std::move(s));
  if (was) start();
  return mirror;
}

std::unique_ptr<PortSet> RtHost::forget(Component& c) {
  const bool was = running();
  stop();
  auto& I = *impl_;
  const std::uint16_t i = I.index_of(c);
  if (i == 0xffff) {
    if (was) start();
    return nullptr;
  }
  c.halt();  // its actuators' zeros go to the ring, then to the mirror
  I.send_unsent();  // (the thread is stopped: this thread may fill its rings)
  I.drain();
  I.send_unsent();
  I.drain();
  std::erase_if(I.routes, [i](const std::unique_ptr<RouteLink>& r) {
    if (r->from != i && r->to != i) return false;
    r->out->detach(r.get());
    return true;
  });
  auto& s = *I.slots[i];
  const auto& outs = c.ports().outputs();
  for (std::size_t p = 0; p < outs.size() && p < s.links.size(); ++p) outs[p]->detach(s.links[p].get());
  for (const auto& in : s.mirror->inputs()) in->on_sample = nullptr;
  const auto& ins = c.ports().inputs();
  for (std::size_t p = 0; p < ins.size() && p < s.pulls.size(); ++p) ins[p]->remove_pull_source(s.pulls[p].get());
  c.on_event = nullptr;
  auto mirror = std::move(s.mirror);
  I.slots[i].reset();
  if (was) start();
  return mirror;
}

bool RtHost::link(Component& from, const std::string& out, Component& to, const std::string& in,
                  const std::string& set, std::uint32_t queue, std::string* error) {
  auto& I = *impl_;
  const std::uint16_t f = I.index_of(from), t = I.index_of(to);
  Output* o = from.ports().find_output(out);
  Input* n = to.ports().find_input(in);
  if (f == 0xffff || t == 0xffff) return *error = "not both on the real-time thread", false;
  if (!o) return *error = from.ports().no_such_output(from.name(), out), false;
  if (!n) return *error = to.ports().no_such_input(to.name(), in), false;
  if (auto why = compatibility_error(o->spec(), n->spec()); !why.empty()) return *error = why, false;
  for (const auto& r : I.routes)  // connected again: the same link
    if (r->out == o && r->in == n && r->info.set == set) return true;
  const bool was = running();
  stop();
  n->reserve_queue(queue);
  auto r = std::make_unique<RouteLink>();
  r->from = f;
  r->to = t;
  r->out = o;
  r->in = n;
  r->info = {from.name(), out, to.name(), in, set};
  o->attach(r.get());
  I.routes.push_back(std::move(r));
  if (was) start();
  return true;
}

std::size_t RtHost::activate(const std::string& set, const Component& from, bool active) {
  const std::uint16_t f = impl_->index_of(from);
  std::size_t n = 0;
  for (const auto& r : impl_->routes)
    if (r->from == f && r->info.set == set) r->active.store(active, std::memory_order_relaxed), ++n;
  return n;
}

void RtHost::unlink(const std::string& set) {
  auto& I = *impl_;
  if (std::none_of(I.routes.begin(), I.routes.end(), [&](const auto& r) { return r->info.set == set; })) return;
  const bool was = running();
  stop();
  std::erase_if(I.routes, [&](const std::unique_ptr<RouteLink>& r) {
    if (r->info.set != set) return false;
    r->out->detach(r.get());
    return true;
  });
  if (was) start();
}

std::vector<RtHost::LinkInfo> RtHost::links(const Component& from) const {
  const std::uint16_t f = impl_->index_of(from);
  std::vector<LinkInfo> v;
  for (const auto& r : impl_->routes) {
    if (r->from != f) continue;
    v.push_back(r->info);
    v.back().active = r->active.load(std::memory_order_relaxed);
    v.back().sent = r->sent.load(std::memory_order_relaxed);
    v.back().skipped = r->skipped.load(std::memory_order_relaxed);
  }
  return v;
}

void RtHost::request(Component& c, Op op, std::string a, std::string b, Reply done) {
  auto& I = *impl_;
  const std::uint16_t slot = I.index_of(c);
  if (slot == 0xffff) return done(c.name() + " does not run on the real-time thread");
  auto p = std::make_unique<Impl::Pending>();
  p->a = std::move(a);
  p->b = std::move(b);
  p->done = std::move(done);
  const Command cmd{++I.seq, op, slot, &p->a, &p->b, &p->error};
  // at most as many requests unanswered as the answers ring holds: the thread's answer always finds room
  if (I.pending.size() >= Impl::kAnswers || !I.commands.push(cmd)) return p->done(c.name() + ": too many requests waiting for the real-time thread");
  I.pending.emplace(cmd.seq, std::move(p));  // taken at the thread's next wake (kIdle at the latest)
  I.wait();
}

std::string RtHost::start() {
  auto& I = *impl_;
  if (running()) return "";
  std::string memory;
  if (!I.started_once) memory = rt::setup_process(I.config);
  I.stop.store(false);
  std::promise<std::string> ready;
  auto told = ready.get_future();
  I.thread = std::thread([&I, &ready] {
    ready.set_value(rt::setup_thread(I.config));
    I.run();
  });
  const std::string thread = told.get();
  const bool first = !I.started_once;
  I.started_once = true;
  I.wait();
  return first ? rt::warning(I.config, memory, thread) : "";
}

void RtHost::stop() {
  auto& I = *impl_;
  if (!running()) return;
  I.stop.store(true, std::memory_order_relaxed);
  I.thread.join();
  I.drain();
}

std::optional<RtLeafStats> RtHost::stats(const Component& c) const {
  const RtSlot* s = impl_->slot_of(c);
  if (!s) return std::nullopt;
  return RtLeafStats{s->runs.load(std::memory_order_relaxed), s->overruns.load(std::memory_order_relaxed),
                     s->missed.load(std::memory_order_relaxed), s->period.load(std::memory_order_relaxed),
                     s->wake.summary(), s->exec.summary(), s->wake.buckets(), s->exec.buckets()};
}

// ------------------------------------------------------------------------------------- on the thread ---

void RtHost::Impl::run() {
  tid.store(static_cast<long>(::gettid()));
  rt::contract::enter();
  while (!stop.load(std::memory_order_relaxed)) {
    const Nanos now = monotonic_now();
    sleep_until(std::min(timers.next_deadline().value_or(kNever), now + kIdle));
    if (stop.load(std::memory_order_relaxed)) break;
    send_unsent();
    take_commands();
    take_samples();
    timers.run_due();
    notify();
    // page faults are counted with the hooks or without them (getrusage: one system call, after the wake's
    // work and its notification); allocations and locks only where the hooks are linked
    publish_counts();
  }
  rt::contract::leave();
}

void RtHost::Impl::take_commands() {
  for (Command c; commands.pop(c);) {
    RtSlot* s = c.slot < slots.size() ? slots[c.slot].get() : nullptr;
    bool ok = false;
    if (s) {
      switch (c.op) {
        case Op::Configure: ok = s->c->configure(c.error); break;
        case Op::Start:
          ok = s->c->start({reinterpret_cast<const std::byte*>(c.a->data()), c.a->size()}, c.error);
          break;
        case Op::Halt: s->c->halt(), ok = true; break;
        case Op::SetParameter: ok = s->c->set_parameter(*c.a, *c.b, c.error); break;
      }
    }
    answers.push({c.seq, ok});  // never full: request() keeps at most kAnswers unanswered
    pushed = true;
  }
}

void RtHost::Impl::take_samples() {
  for (Sample s; in.pop(s);) {
    RtSlot* slot = s.slot < slots.size() ? slots[s.slot].get() : nullptr;
    if (!slot || s.port >= slot->c->ports().inputs().size()) continue;
    Input& input = *slot->c->ports().inputs()[s.port];
    if (s.pulled) input.deliver_pulled({s.data, s.size});
    else input.deliver({s.data, s.size});
  }
}

void RtHost::Impl::publish_counts() {
  const auto c = rt::contract::counts();
  allocations.store(c.allocations, std::memory_order_relaxed);
  locks.store(c.locks, std::memory_order_relaxed);
  faults.store(c.page_faults, std::memory_order_relaxed);
}

// After each timer callback: the leaf whose timer it was (timers are named by their component's PATH).
void RtHost::Impl::on_ran(const std::string& name, Nanos deadline, Nanos p, Nanos start, Nanos end) {
  for (const auto& s : slots) {
    if (!s || s->c->name() != name) continue;
    s->wake.record(start - deadline);
    s->exec.record(end - start);
    add(s->runs, std::uint64_t{1});
    s->period.store(p, std::memory_order_relaxed);
    // an overrun: the run ended after its next deadline. Missed: the deadlines already gone by when it started,
    // which its TimerServer skipped (TimerServer::set_driven); those its run went past are counted when the next
    // run starts, so a period is never counted twice
    if (p > 0 && end > deadline + p) add(s->overruns, std::uint64_t{1});
    if (p > 0 && start >= deadline + p) add(s->missed, static_cast<std::uint64_t>((start - deadline - p) / p + 1));
    return;
  }
}

// ------------------------------------------------------------------------------------ on the I/O thread ---

void RtHost::Impl::wait() {
  if (waiting || !*alive) return;
  waiting = true;
  efd.async_wait(asio::posix::stream_descriptor::wait_read, [this, a = alive](const boost::system::error_code& ec) {
    if (!*a) return;
    waiting = false;
    if (ec) return;
    std::uint64_t n = 0;
    [[maybe_unused]] const auto r = ::read(efd.native_handle(), &n, sizeof n);
    drain();
    wait();
  });
}

// What the thread sent: the answers and ends of runs taken first, then the samples (written before them), then
// the ends and answers told, in that order.
void RtHost::Impl::drain() {
  std::vector<Answer> told;
  std::vector<Event> ended;
  for (Answer a; answers.pop(a);) told.push_back(a);
  for (Event e; events.pop(e);) ended.push_back(e);
  for (Pull p; pulls.pop(p);) {
    RtSlot* slot = p.slot < slots.size() ? slots[p.slot].get() : nullptr;
    if (slot && p.port < slot->mirror->inputs().size()) slot->mirror->inputs()[p.port]->request();
  }
  for (Sample s; out.pop(s);) {
    RtSlot* slot = s.slot < slots.size() ? slots[s.slot].get() : nullptr;
    if (slot && s.port < slot->mirror->outputs().size()) slot->mirror->outputs()[s.port]->write_bytes({s.data, s.size});
  }
  for (const auto& e : ended) {
    std::unique_ptr<ComponentEvent> ev(e.event);
    RtSlot* slot = e.slot < slots.size() ? slots[e.slot].get() : nullptr;
    if (slot && slot->on_event) slot->on_event(*ev);
  }
  for (const auto& a : told) {
    auto it = pending.find(a.seq);
    if (it == pending.end()) continue;
    auto p = std::move(it->second);
    pending.erase(it);
    p->done(a.ok ? std::string() : p->error.empty() ? std::string("refused") : p->error);
  }
}

}  // namespace dca
