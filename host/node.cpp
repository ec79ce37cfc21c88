#include "host/node.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <set>

#include "host/auth.h"
#include "host/channel.h"
#include "host/endpoint.h"
#include "host/paths.h"

namespace dca {

using wire::Message;
using wire::Value;

namespace {

Value spec_value(const PortSpec& s) {
  return Value::map()
      .set("name", s.name)
      .set("type", std::string(to_string(s.type)))
      .set("size", static_cast<std::int64_t>(s.size))
      .set("units", s.units);
}

Value latest_value(const Port& p) {
  msgpack::sbuffer sb;
  msgpack::packer<msgpack::sbuffer> pk(sb);
  p.pack_latest(pk);
  return value_from_msgpack({reinterpret_cast<const std::byte*>(sb.data()), sb.size()});
}

}  // namespace

Value value_from_msgpack(Bytes b) {
  Value v;
  if (!wire::decode_value({reinterpret_cast<const char*>(b.data()), b.size()}, v)) return {};
  return v;
}

std::string msgpack_from_value(const Value& v) {
  std::string out;
  wire::encode_value(v, out);
  return out;
}

struct Node::Impl {
  Impl(Node* n, Loop& l, NodeOptions o, ComponentFactory f)
      : node(n), loop(l), opts(std::move(o)), factory(std::move(f)) {}
  Node* node;  // the owner (shutdown)
  Loop& loop;
  NodeOptions opts;
  ComponentFactory factory;
  ChannelOptions chopts;
  std::unique_ptr<TimerServer> timers;
  std::unique_ptr<Endpoint> endpoint;
  std::unique_ptr<Component> component;
  Channel::Ptr daemon;
  Channel::Ptr master;  // the clock master (simulated time)
  std::function<bool(const Channel::Ptr&, const Message&)> hook;
  Listener::Ptr control;
  std::set<Channel::Ptr> supervisors;
  std::string ip;  // the daemon's IP: where this node listens
  std::string uds;
  bool done = false;
  int code = 0;

  void fail_start(const std::function<void(const std::string&)>& done_fn, const std::string& error) {
    code = 1;
    done_fn(error);
  }

  void event(Message m) {
    for (const auto& ch : supervisors)
      if (ch->is_open()) ch->send(m);
  }

  using Done = std::function<void(const std::string&)>;
  void connect_daemon(const Address& address, Done done_fn);
  void learn_host(const Done& done_fn);
  void open_ports(const std::string& host, const Done& done_fn);
  void forward(const ComponentEvent& e);
  void forward(const CommsEvent& e);
  void listen_control(const std::string& host, const Done& done_fn);
  void register_node(const std::string& host, const Done& done_fn);
  void subscribe(const Done& done_fn);
  void connect_master(const Address& address, const Done& done_fn);
  void handle(const Channel::Ptr& ch, const Message& m);
  void connect(const Channel::Ptr& ch, const Message& m);
  void pull(const Channel::Ptr& ch, const Message& m);
  Value ports() const;
  Value stats() const;
};

Node::Node(Loop& loop, NodeOptions options, ComponentFactory factory)
    : impl_(std::make_unique<Impl>(this, loop, std::move(options), std::move(factory))) {}

Node::~Node() { shutdown("node destroyed"); }

bool Node::finished() const { return impl_->done; }
void Node::on_request(std::function<bool(const std::shared_ptr<Channel>&, const wire::Message&)> hook) {
  impl_->hook = std::move(hook);
}
int Node::exit_code() const { return impl_->code; }

// Start-up as a list of named steps, each ending by calling the next one or fail_start:
//   start (key, daemon address) -> connect_daemon -> learn_host (ping, unless --host) -> open_ports ->
//   listen_control -> register_node -> subscribe (simulated time: lookup, connect, clock; see below).
void Node::start(std::function<void(const std::string& error)> done) {
  auto& I = *impl_;
  std::string error;
  auto key = auth::load_key(auth::key_file_path(I.opts.key_file), &error);
  if (!key) return I.fail_start(done, error);
  I.chopts.key = *key;
  I.chopts.handshake_timeout = std::chrono::milliseconds(I.opts.timeout_ms);
  const auto daddr = Address::parse(I.opts.daemon, &error);
  if (!daddr) return I.fail_start(done, error);
  I.ip = daddr->kind == Address::Kind::kTcp ? daddr->host : "127.0.0.1";
  I.connect_daemon(*daddr, std::move(done));
}

// Opens the channel to the daemon (losing it stops the node), then learns the host's name.
void Node::Impl::connect_daemon(const Address& address, Done done_fn) {
  Channel::connect(loop.io(), address, chopts, [this, done_fn](Channel::Ptr ch, const std::string& err) {
    if (!ch) return fail_start(done_fn, "cannot reach the daemon at " + opts.daemon + ": " + err);
    daemon = ch;
    ch->on_close([this](const std::string& reason) {
      if (done) return;
      std::fprintf(stderr, "dca node %s: the daemon's channel closed (%s): stopping\n", opts.name.c_str(),
                   reason.c_str());
      code = 1;
      node->shutdown("daemon lost");
      loop.stop();
    });
    learn_host(done_fn);
  });
}

// The host's name: --host, else the daemon's answer to ping; then the node's ports.
void Node::Impl::learn_host(const Done& done_fn) {
  if (!opts.host.empty()) return open_ports(opts.host, done_fn);
  daemon->request({"ping", 0, Value::map()}, std::chrono::milliseconds(opts.timeout_ms), [this, done_fn](Response r) {
    if (!r.ok()) return fail_start(done_fn, "the daemon did not answer ping: " + r.error);
    open_ports(r.message.payload["host"].as_string(), done_fn);
  });
}

// Makes the timers, the component and the data endpoint (listening on a socket of its own), then the
// control listener.
void Node::Impl::open_ports(const std::string& host, const Done& done_fn) {
  try {
    timers = std::make_unique<TimerServer>(loop.io(), opts.clock);
    timers->set_aligned(opts.clock == ClockKind::Simulated);
    component = factory(opts.type, opts.name, host, opts.args, *timers);
    EndpointOptions eo;
    eo.key = chopts.key;  // data connections authenticate with the cluster key too
    eo.handshake_timeout = std::chrono::milliseconds(opts.timeout_ms);
    endpoint = std::make_unique<Endpoint>(loop.io(), host, std::move(eo));
    static int made = 0;  // several nodes in one process (tests) need distinct sockets
    uds = runtime_dir() + "/node-" + std::to_string(::getpid()) + (made++ ? "-" + std::to_string(made) : "") + ".sock";
    endpoint->listen(uds, ip + ":0");
    endpoint->add_component(opts.name, component->ports());
  } catch (const std::exception& e) {
    return fail_start(done_fn, e.what());
  }
  component->on_event = [this](const ComponentEvent& e) { forward(e); };
  endpoint->on_event([this](const CommsEvent& e) { forward(e); });
  listen_control(host, done_fn);
}

// Tells the supervisors that the component finished or aborted (`now`: on this node's clock, as in `advance`).
void Node::Impl::forward(const ComponentEvent& e) {
  if (e.kind == ComponentEvent::Kind::Done)
    event({"done", 0,
           Value::map().set("name", opts.name).set("now", timers->now()).set("value", value_from_msgpack(
               {reinterpret_cast<const std::byte*>(e.value.data()), e.value.size()}))});
  else
    event({"aborted", 0, Value::map().set("name", opts.name).set("now", timers->now()).set("reason", e.reason)});
}

// Tells the supervisors that a data link broke or a port overflowed.
void Node::Impl::forward(const CommsEvent& e) {
  if (e.kind == CommsEvent::Kind::Broken)
    event({"broken", 0, Value::map().set("name", e.component).set("port", e.port).set("peer", e.peer)
                             .set("set", e.set).set("reason", e.reason)});
  else
    event({"overflow", 0, Value::map().set("name", e.component).set("port", e.port).set("reason", e.reason)});
}

// Listens for supervisors' control channels on the daemon's IP, then registers.
void Node::Impl::listen_control(const std::string& host, const Done& done_fn) {
  std::string lerr;
  control = Listener::listen(loop.io(), *Address::parse(ip + ":0"), chopts, [this](Channel::Ptr sup) {
    supervisors.insert(sup);
    std::weak_ptr<Channel> w = sup;
    sup->on_message([this, w](const Message& m) {
      if (auto s = w.lock()) handle(s, m);
    });
    sup->on_close([this, w](const std::string&) {
      if (auto s = w.lock()) supervisors.erase(s);
    });
  }, &lerr);
  if (!control) return fail_start(done_fn, "cannot listen for control channels: " + lerr);
  register_node(host, done_fn);
}

// Registers the node's endpoints with the daemon; on simulated time, then subscribes to the clock master.
void Node::Impl::register_node(const std::string& host, const Done& done_fn) {
  const auto loc = endpoint->location();
  Value endpoints = Value::map()
                        .set("host", host)
                        .set("control", control->address().str())
                        .set("data_uds", loc.data_uds)
                        .set("data_tcp", loc.data_tcp)
                        .set("pid", static_cast<std::int64_t>(::getpid()))
                        .set("type", opts.type);
  daemon->request({"register", 0, Value::map().set("name", opts.name).set("endpoints", endpoints)},
                  std::chrono::milliseconds(opts.timeout_ms), [this, done_fn](Response r) {
                    if (!r.ok()) return fail_start(done_fn, "cannot register " + opts.name + ": " + r.error);
                    if (opts.clock == ClockKind::Simulated && !opts.world.empty()) return subscribe(done_fn);
                    done_fn("");
                  });
}

void Node::shutdown(const std::string& why) {
  auto& I = *impl_;
  if (I.done) return;
  I.done = true;
  if (I.component) I.component->halt();
  if (I.endpoint && I.component) I.endpoint->remove_component(I.opts.name);
  I.endpoint.reset();
  if (I.control) I.control->close();
  if (I.master) {
    auto c = I.master;
    I.master.reset();
    c->close(why);
  }
  for (auto ch : std::set<Channel::Ptr>(I.supervisors)) ch->close(why);
  I.supervisors.clear();
  if (I.daemon) {
    auto d = I.daemon;
    I.daemon.reset();
    d->close(why);
  }
}

// Simulated time, step 1: look the clock master up by name (waiting for it to register; see node.h).
void Node::Impl::subscribe(const Done& done_fn) {
  const auto timeout = std::chrono::milliseconds(opts.timeout_ms);
  daemon->request(
      {"lookup", 0, Value::map().set("name", opts.world).set("wait_ms", static_cast<std::int64_t>(opts.timeout_ms))},
      timeout + std::chrono::milliseconds(1000), [this, done_fn](Response r) {
        if (done) return;
        const std::string who = opts.name + " (simulated clock)";
        if (!r.ok())
          return fail_start(done_fn, who + ": no clock master '" + opts.world + "' (the world, `dca sim --serve`): " +
                                         r.error);
        std::string err;
        const auto addr = Address::parse(r.message.payload["endpoints"]["control"].as_string(), &err);
        if (!addr) return fail_start(done_fn, who + ": the clock master's control address: " + err);
        connect_master(*addr, done_fn);
      });
}

// Simulated time, step 2: connect to the clock master (losing it stops the node), subscribe, take its time.
void Node::Impl::connect_master(const Address& address, const Done& done_fn) {
  Channel::connect(loop.io(), address, chopts, [this, done_fn](Channel::Ptr ch, const std::string& e) {
    if (done) return;
    const std::string who = opts.name + " (simulated clock)";
    if (!ch) return fail_start(done_fn, who + ": cannot reach the clock master '" + opts.world + "': " + e);
    master = ch;
    std::weak_ptr<Channel> w = ch;
    ch->on_message([this, w](const Message& m) {
      if (auto c = w.lock()) handle(c, m);
    });
    ch->on_close([this](const std::string& reason) {
      if (done || !master) return;
      std::fprintf(stderr, "dca node %s: the clock master '%s' closed its channel (%s): stopping\n",
                   opts.name.c_str(), opts.world.c_str(), reason.c_str());
      code = 1;
      master.reset();
      boost::asio::post(loop.io(), [this] { loop.stop(); });
    });
    ch->request({"clock", 0, Value::map().set("name", opts.name)}, std::chrono::milliseconds(opts.timeout_ms),
                [this, done_fn, who](Response r) {
                  if (done) return;
                  if (!r.ok()) return fail_start(done_fn, who + ": the clock master refused the subscription: " + r.error);
                  const Nanos now = r.message.payload["now"].as_int(0);
                  if (now > timers->now()) timers->advance_to(now);
                  done_fn("");
                });
  });
}

Value Node::Impl::ports() const {
  Value ins = Value::array(), outs = Value::array(), links = Value::array();
  for (const auto& p : component->ports().inputs()) {
    auto v = spec_value(p->spec());
    v.set("samples", p->stats().samples).set("dropped", p->stats().dropped).set("rejected", p->stats().rejected);
    v.set("queued", static_cast<std::uint64_t>(p->queued())).set("capacity", static_cast<std::uint64_t>(p->capacity()));
    ins.array_ref().push_back(std::move(v));
  }
  for (const auto& p : component->ports().outputs()) {
    auto v = spec_value(p->spec());
    v.set("samples", p->stats().samples).set("rejected", p->stats().rejected);
    outs.array_ref().push_back(std::move(v));
  }
  for (const auto& l : endpoint->links()) {
    links.array_ref().push_back(Value::map()
                                    .set("out", l.request.out)
                                    .set("to", l.request.to)
                                    .set("in", l.request.in)
                                    .set("set", l.request.set)
                                    .set("mode", std::string(to_string(l.request.mode)))
                                    .set("transport", std::string(to_string(l.transport)))
                                    .set("active", l.active)
                                    .set("broken", l.broken)
                                    .set("sent", l.sent)
                                    .set("skipped", l.skipped)
                                    .set("tx_dropped", l.tx_dropped)
                                    .set("bytes", l.bytes));
  }
  return Value::map().set("inputs", ins).set("outputs", outs).set("links", links)
      .set("accepted", static_cast<std::uint64_t>(endpoint->accepted()))
      .set("bytes_received", endpoint->bytes_received())
      .set("refused", endpoint->refused());
}

Value Node::Impl::stats() const {
  Value ts = Value::array();
  for (const auto& s : timers->stats())
    ts.array_ref().push_back(Value::map()
                                 .set("name", s.name)
                                 .set("period_s", to_seconds(s.period))
                                 .set("active", s.active)
                                 .set("count", s.count)
                                 .set("missed", s.missed)
                                 .set("p50_us", s.p50_us)
                                 .set("p99_us", s.p99_us)
                                 .set("max_us", s.max_us));
  auto summary = [](const IntervalSummary& i) {
    return Value::map()
        .set("n", i.n)
        .set("p50_us", i.p50_us)
        .set("p99_us", i.p99_us)
        .set("p999_us", i.p999_us)
        .set("max_us", i.max_us)
        .set("min_us", i.min_us)
        .set("mean_us", i.mean_us);
  };
  Value iv = Value::array();
  for (const auto& s : timers->interval_stats())
    iv.array_ref().push_back(Value::map()
                                 .set("name", s.name)
                                 .set("period_s", to_seconds(s.period))
                                 .set("clock", summary(s.clock))
                                 .set("wall", summary(s.wall)));
  return Value::map().set("timers", ts).set("intervals", iv).set("clock", to_string(timers->kind()));
}

void Node::Impl::connect(const Channel::Ptr& ch, const Message& m) {
  const auto& p = m.payload;
  ConnectRequest r;
  r.from = opts.name;
  r.out = p["out"].as_string();
  r.to = p["to"].as_string();
  r.in = p["in"].as_string();
  r.set = p["set"].as_string();
  const std::string mode = p["mode"].is_nil() ? "push" : p["mode"].as_string();
  const auto md = mode_from(mode);
  if (!md) return void(ch->reply_error(m, "connect: mode must be push or pull, not '" + mode + "'"));
  r.mode = *md;
  r.queue = static_cast<std::uint32_t>(p["queue"].is_nil() ? 16 : std::max<std::int64_t>(1, p["queue"].as_int(16)));
  if (r.out.empty() || r.to.empty() || r.in.empty())
    return void(ch->reply_error(m, "connect needs out, to and in"));
  const int timeout = opts.timeout_ms;
  auto finish = [this, ch, m](const std::string& error) {
    if (!endpoint) return;
    if (!error.empty()) return void(ch->reply_error(m, error));
    Value t = "";
    for (const auto& l : endpoint->links())
      if (l.request.out == m.payload["out"].as_string() && l.request.to == m.payload["to"].as_string() &&
          l.request.in == m.payload["in"].as_string() && l.request.set == m.payload["set"].as_string())
        t = std::string(to_string(l.transport));
    ch->reply(m, Value::map().set("transport", t));
  };
  if (endpoint->component(r.to)) return endpoint->connect(r, {}, finish, timeout);
  daemon->request({"lookup", 0, Value::map().set("name", r.to).set("wait_ms", static_cast<std::int64_t>(timeout))},
                  std::chrono::milliseconds(timeout + 1000), [this, r, finish, timeout](Response resp) {
                    if (!endpoint) return;
                    if (!resp.ok()) return finish("connect: cannot find " + r.to + ": " + resp.error);
                    const auto& e = resp.message.payload["endpoints"];
                    Location loc{e["host"].as_string(), e["data_uds"].as_string(), e["data_tcp"].as_string()};
                    if (loc.host.empty()) loc.host = resp.message.payload["host"].as_string();
                    endpoint->connect(r, loc, finish, timeout);
                  });
}

// pull {port, timeout_ms}: asks the input's pull connections for their latest sample and answers with it
// when it arrives (checked every millisecond), or an error at the deadline.
void Node::Impl::pull(const Channel::Ptr& ch, const Message& m) {
  const auto& name = m.payload["port"].as_string();
  Input* in = component->ports().find_input(name);
  if (!in) return void(ch->reply_error(m, component->ports().no_such_input(opts.name, name)));
  const std::uint64_t before = in->stats().samples;
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::milliseconds(m.payload["timeout_ms"].as_int(opts.timeout_ms));
  in->request();
  auto timer = std::make_shared<boost::asio::steady_timer>(loop.io());
  auto check = std::make_shared<std::function<void()>>();
  // The function holds itself weakly; each pending wait holds it strongly, so it is freed when the chain ends.
  std::weak_ptr<std::function<void()>> self = check;
  *check = [this, ch, m, in, before, deadline, timer, self, name] {
    if (done || !component) return;
    if (in->stats().samples > before)
      return void(ch->reply(m, Value::map().set("value", latest_value(*in)).set("count", in->stats().samples)));
    if (std::chrono::steady_clock::now() >= deadline)
      return void(ch->reply_error(m, "pull: no sample arrived at " + opts.name + "." + name + " in time"));
    timer->expires_after(std::chrono::milliseconds(1));
    timer->async_wait([strong = self.lock()](const boost::system::error_code& ec) {
      if (!ec && strong) (*strong)();
    });
  };
  (*check)();
}

void Node::Impl::handle(const Channel::Ptr& ch, const Message& m) {
  if (done || !component) return void(ch->reply_error(m, "node " + opts.name + " is stopping"));
  const auto& t = m.type;
  const auto& p = m.payload;
  if (t == "init") {
    std::string err;
    if (!component->configure(&err)) return void(ch->reply_error(m, err));
    return void(ch->reply(m));
  }
  if (t == "run") {
    const std::string init = p.find("init") ? msgpack_from_value(p["init"]) : std::string();
    std::string err;
    if (!component->start({reinterpret_cast<const std::byte*>(init.data()), init.size()}, &err))
      return void(ch->reply_error(m, err));
    return void(ch->reply(m));
  }
  if (t == "stop") {
    component->halt();
    return void(ch->reply(m));
  }
  if (t == "connect") return connect(ch, m);
  if (t == "disconnect") {
    endpoint->disconnect_set(p["set"].as_string());
    return void(ch->reply(m));
  }
  if (t == "activate" || t == "deactivate") {
    const auto& set = p["set"].as_string();
    if (set.empty()) return void(ch->reply_error(m, t + " needs a set"));
    if (t == "activate") endpoint->activate(set);
    else endpoint->deactivate(set);
    return void(ch->reply(m));
  }
  if (t == "read") {
    const auto& name = p["port"].as_string();
    auto& ps = component->ports();
    const Port* port = ps.find_output(name);
    if (!port) port = ps.find_input(name);
    if (!port) {
      std::string valid;
      for (const auto& o : ps.outputs()) valid += (valid.empty() ? "" : ", ") + o->name();
      for (const auto& i : ps.inputs()) valid += (valid.empty() ? "" : ", ") + i->name();
      return void(ch->reply_error(m, "no port '" + name + "' on " + opts.name + "; ports are: " +
                                         (valid.empty() ? std::string("(none)") : valid)));
    }
    return void(ch->reply(m, Value::map().set("value", latest_value(*port)).set("count", port->stats().samples)));
  }
  if (t == "pull") return pull(ch, m);
  if (t == "ports") return void(ch->reply(m, ports()));
  if (t == "stats") return void(ch->reply(m, stats()));
  if (t == "advance") {
    if (timers->kind() != ClockKind::Simulated)
      return void(ch->reply_error(m, "advance: node " + opts.name + " runs on the wall clock"));
    const Nanos at = p["t"].as_int(-1);
    if (at < timers->now()) return void(ch->reply_error(m, "advance: t must be >= now (" + std::to_string(timers->now()) + ")"));
    // Drain: every sample sent to this node before the master asked is in its sockets; take it in first, so
    // that a sample written at one tick is always seen at the next (runs repeat exactly).
    loop.settle();
    if (done || !component) return;
    timers->advance_to(at);
    // Flush what the timers wrote before answering: the master moves on only when it is on its way.
    loop.settle();
    if (done || !component) return;
    const auto next = timers->next_deadline();
    return void(ch->reply(m, Value::map().set("now", timers->now()).set("next", next ? Value(*next) : Value())));
  }
  if (t == "exit") {
    ch->reply(m);
    boost::asio::post(loop.io(), [this] { loop.stop(); });  // the caller of run() then calls shutdown()
    return;
  }
  if (hook && hook(ch, m)) return;
  if (m.id == 0) {
    // an event this node has no use for (e.g. the world's `broken`/`overflow`, sent to every channel it
    // accepted, clock subscribers included): answering it as an error would close the channel
    return;
  }
  ch->reply_error(m, "unknown request '" + t + "' for node " + opts.name);
}

}  // namespace dca
