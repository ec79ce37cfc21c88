#include "host/node.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <optional>
#include <set>

#include "host/net/auth.h"
#include "host/net/channel.h"
#include "host/net/endpoint.h"
#include "host/node_rt.h"
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

// The crash note of a shared node (node.h): a small file mapped in memory that holds the PATH of the leaf
// whose code runs now (empty between callbacks), so that whatever ends the process, the daemon finds there
// whose code ran. A copy into memory per callback, no system call.
constexpr std::size_t kCrashNote = 256;
char* g_crash_note = nullptr;

void note_leaf(const std::string* leaf) {
  if (!g_crash_note) return;
  if (!leaf) {
    g_crash_note[0] = '\0';
    return;
  }
  const std::size_t n = std::min(leaf->size(), kCrashNote - 1);
  std::memcpy(g_crash_note, leaf->data(), n);
  g_crash_note[n] = '\0';
}

void open_crash_note() {
  const int fd = ::open(crash_note_path(::getpid()).c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0600);
  if (fd < 0) return;
  if (::ftruncate(fd, kCrashNote) == 0) {
    void* m = ::mmap(nullptr, kCrashNote, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    if (m != MAP_FAILED) g_crash_note = static_cast<char*>(m);
  }
  ::close(fd);
}

// A fatal signal sent by another process (kill -SEGV, not a fault of the code that ran) is nobody's crash: the
// note is cleared, then the signal ends the node as it would have. Installed only where the disposition is the
// default (a sanitizer's own handler stays); a fault of the code itself (si_code > 0) or the node's own raise()
// or abort() keeps the note.
void external_fatal(int sig, siginfo_t* info, void*) {
  if (info && info->si_code <= 0 && info->si_pid != ::getpid() && g_crash_note) g_crash_note[0] = '\0';
  ::raise(sig);  // SA_RESETHAND made the action the default; blocked in the handler, delivered when it returns
}

void clear_note_on_external_signals() {
  for (const int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) {
    struct sigaction old {};
    if (::sigaction(sig, nullptr, &old) != 0 || (old.sa_flags & SA_SIGINFO) || old.sa_handler != SIG_DFL) continue;
    struct sigaction sa {};
    sa.sa_sigaction = external_fatal;
    sa.sa_flags = SA_SIGINFO | SA_RESETHAND;
    ::sigemptyset(&sa.sa_mask);
    ::sigaction(sig, &sa, nullptr);
  }
}

// Notes the leaf whose component code runs in this scope (a control request), and clears the note after.
struct CrashScope {
  explicit CrashScope(const std::string& leaf) { note_leaf(&leaf); }
  ~CrashScope() { note_leaf(nullptr); }
  CrashScope(const CrashScope&) = delete;
  CrashScope& operator=(const CrashScope&) = delete;
};

}  // namespace

std::string crash_note_path(int pid) { return runtime_dir() + "/node-" + std::to_string(pid) + ".crash"; }

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

namespace {

// One hosted leaf: its component, its own control listener and the channels its supervisors opened there.
struct Leaf {
  std::string type, name;
  std::string package, system_dir;  // a shared node's leaf of a package's type: what its `add` named
  std::uint64_t instance = 0;  // this process's count of leaves added, at its add (Location::instance)
  std::unique_ptr<Component> component;
  PortSet* ports = nullptr;  // what the endpoint and the control plane see: the component's, or its mirror (on_rt)
  bool on_rt = false;        // its component runs on one of the node's real-time threads (host/node_rt.h)
  RtHost* rt = nullptr;      // that thread (on_rt)
  std::unique_ptr<PortSet> mirror;  // its mirror once the thread let it go (RtHost::forget), for the endpoint
  Listener::Ptr control;
  std::shared_ptr<std::set<Channel::Ptr>> supervisors = std::make_shared<std::set<Channel::Ptr>>();

  void event(const Message& m) const {
    for (const auto& ch : *supervisors)
      if (ch->is_open()) ch->send(m);
  }
};

}  // namespace

struct Node::Impl {
  Impl(Node* n, Loop& l, NodeOptions o, ComponentFactory f)
      : node(n), loop(l), opts(std::move(o)), factory(std::move(f)) {}
  Node* node;  // the owner (shutdown)
  Loop& loop;
  NodeOptions opts;
  ComponentFactory factory;
  ChannelOptions chopts;
  std::unique_ptr<TimerServer> timers;
  // The real-time threads (wall clock), before the leaves: they outlive them. One per distinct setting: the
  // node's own (NodeOptions::rt), and in a shared node those its `add` requests name ({priority, cpu}).
  std::map<std::pair<int, int>, std::unique_ptr<RtHost>> rts;
  RtHost* rt = nullptr;  // the node's own (NodeOptions::rt), or none
  RtHost* rt_for(rt::RtConfig c);
  std::unique_ptr<Endpoint> endpoint;
  std::map<std::string, std::shared_ptr<Leaf>, std::less<>> leaves;
  Channel::Ptr daemon;
  Channel::Ptr master;  // the clock master (simulated time)
  std::function<bool(const Channel::Ptr&, const Message&)> hook;
  std::function<void(const Message&)> before_hook;  // before_request
  Listener::Ptr control;            // a shared node's own control address (add, remove, advance, exit)
  std::shared_ptr<std::set<Channel::Ptr>> channels = std::make_shared<std::set<Channel::Ptr>>();  // accepted there
  std::string ip;  // the daemon's IP: where this node listens
  std::string host;
  std::string uds;
  bool done = false;
  int code = 0;

  bool failure_told = false;  // the daemon took the reason of a failed start (it goes with the exit event)
  void fail_start(const std::function<void(const std::string&)>& done_fn, const std::string& error);
  Leaf* find(std::string_view name) const {
    auto it = leaves.find(name);
    return it == leaves.end() ? nullptr : it->second.get();
  }
  // The name the process registers as (a one-leaf node: its leaf's PATH).
  std::string process_name() const {
    return opts.shared ? opts.name + "#" + std::to_string(::getpid()) : opts.name;
  }

  using Done = std::function<void(const std::string&)>;
  void connect_daemon(const Address& address, Done done_fn);
  void learn_host(const Done& done_fn);
  void open_ports(const Done& done_fn);
  using Set = std::shared_ptr<std::set<Channel::Ptr>>;
  Listener::Ptr listen(const Set& set, std::function<void(const Channel::Ptr&, const Message&)> on,
                       std::string* error);
  Leaf* add_leaf(const std::string& type, const std::string& name, const std::vector<std::string>& args,
                 RtHost* on, std::string* error);
  void remove_leaf(const std::string& name);
  Value endpoints(const Leaf* leaf) const;
  void forward(Leaf& leaf, const ComponentEvent& e);
  void forward(const CommsEvent& e);
  void enlist(const Done& done_fn);
  void register_node(const Done& done_fn);
  void subscribe(const Done& done_fn);
  void connect_master(const Address& address, const Done& done_fn);
  void handle(Leaf& leaf, const Channel::Ptr& ch, const Message& m);
  bool handle_control(Leaf& leaf, const Channel::Ptr& ch, const Message& m);
  void handle_process(const Channel::Ptr& ch, const Message& m);
  void add(const Channel::Ptr& ch, const Message& m);
  void advance(const Channel::Ptr& ch, const Message& m);
  void read(Leaf& leaf, const Channel::Ptr& ch, const Message& m);
  void connect(Leaf& leaf, const Channel::Ptr& ch, const Message& m);
  void pull(Leaf& leaf, const Channel::Ptr& ch, const Message& m);
  void set_param(Leaf& leaf, const Channel::Ptr& ch, const Message& m);
  bool rt_control(Leaf& leaf, const Channel::Ptr& ch, const Message& m);
  void start_rt(RtHost& h);
  Value rt_stats(const Leaf& leaf) const;
  std::string take_expected(const Value& expect);
  Value sent_changes();
  Value digests();
  Value advance_reply(bool trace);
  // Tells the clock master which leaves this node hosts (lock-step routes their samples' counts by them).
  void tell_leaves() {
    leaves_told = false;  // and in the next advance's answer
    if (!master) return;
    Value names = Value::array();
    for (const auto& [name, l] : leaves) names.array_ref().push_back(Value(name));
    master->send({"leaves", 0, Value::map().set("leaves", std::move(names))});
  }
  std::map<std::string, std::uint64_t> events;     // per leaf: done and aborted events sent (lock-step counts)
  std::map<std::string, std::uint64_t> last_sent;  // per link key: the count last told to the master
  std::map<std::string, std::uint64_t> evs_told;   // the events per leaf of the last advance's answer
  bool leaves_told = false;                        // the leaves are in an advance's answer since they changed
  std::vector<std::string> switches;               // activations since the last advance (trace)
  std::vector<std::string> params;                 // live parameters changed since the last advance (trace)
  std::uint64_t instances = 0;                      // leaves added so far (each one's Leaf::instance)
  Value ports(const Leaf& leaf) const;
  Value stats(const Leaf& leaf) const;
  Value code_of(const Leaf& leaf) const;
};

Node::Node(Loop& loop, NodeOptions options, ComponentFactory factory)
    : impl_(std::make_unique<Impl>(this, loop, std::move(options), std::move(factory))) {}

Node::~Node() { shutdown("node destroyed"); }

bool Node::finished() const { return impl_->done; }
std::size_t Node::leaves() const { return impl_->leaves.size(); }
void Node::on_request(std::function<bool(const std::shared_ptr<Channel>&, const wire::Message&)> hook) {
  impl_->hook = std::move(hook);
}
void Node::before_request(std::function<void(const wire::Message&)> hook) { impl_->before_hook = std::move(hook); }
int Node::exit_code() const { return impl_->code; }
bool Node::failure_told() const { return impl_->failure_told; }

// Start-up as a list of named steps, each ending by calling the next one or fail_start:
//   start (key, daemon address) -> connect_daemon -> learn_host (ping, unless --host) -> open_ports (the
//   timers, the data endpoint, the one leaf or a shared node's control listener) -> enlist: on simulated time
//   subscribe (lookup, connect, clock; see below), then register_node.
void Node::start(std::function<void(const std::string& error)> done) {
  auto& I = *impl_;
  std::string error;
  auto key = auth::load_key(auth::key_file_path(I.opts.key_file), &error);
  if (!key) return I.fail_start(done, error);
  I.chopts.key = *key;
  I.chopts.handshake_timeout = std::chrono::milliseconds(I.opts.timeout_ms);
  const auto daddr = Address::parse(I.opts.daemon, &error);
  if (!daddr) return I.fail_start(done, error);
  I.ip = daddr->kind == Transport::Tcp ? daddr->host : "127.0.0.1";
  I.connect_daemon(*daddr, std::move(done));
}

// A failed start: once the daemon's channel is open, the reason goes to the daemon first (`failed {pid,
// reason}`, bounded by the start-up timeout), which sends it to the supervisor with the exit event; then
// done_fn. The reason drops the controller's "TYPE PATH: " prefix: the supervisor names the path.
void Node::Impl::fail_start(const std::function<void(const std::string&)>& done_fn, const std::string& error) {
  if (done) return;  // shut down meanwhile (a signal): whoever waited for the start is gone
  code = 1;
  if (!daemon || !daemon->is_open()) return done_fn(error);
  const std::string own = opts.type + " " + opts.name + ": ";
  const std::string reason = error.rfind(own, 0) == 0 ? error.substr(own.size()) : error;
  daemon->request({"failed", 0, Value::map().set("pid", static_cast<std::int64_t>(::getpid())).set("reason", reason)},
                  std::chrono::milliseconds(opts.timeout_ms), [this, done_fn, error](Response r) {
                    if (done) return;
                    failure_told = r.ok();
                    done_fn(error);
                  });
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
  if (!opts.host.empty()) {
    host = opts.host;
    return open_ports(done_fn);
  }
  daemon->request({"ping", 0, Value::map()}, std::chrono::milliseconds(opts.timeout_ms), [this, done_fn](Response r) {
    if (!r.ok()) return fail_start(done_fn, "the daemon did not answer ping: " + r.error);
    host = r.message.payload["host"].as_string();
    open_ports(done_fn);
  });
}

// Makes the timers and the data endpoint (listening on a socket of its own), then the one leaf (a one-leaf
// node) or the control listener (a shared node), then registers.
void Node::Impl::open_ports(const Done& done_fn) {
  std::string error;
  try {
    timers = std::make_unique<TimerServer>(loop.io(), opts.clock);
    timers->set_aligned(opts.clock == ClockKind::Simulated);
    EndpointOptions eo;
    eo.key = chopts.key;  // data connections authenticate with the cluster key too
    eo.handshake_timeout = std::chrono::milliseconds(opts.timeout_ms);
    endpoint = std::make_unique<Endpoint>(loop.io(), host, std::move(eo));
    static int made = 0;  // several nodes in one process (tests) need distinct sockets
    uds = runtime_dir() + "/node-" + std::to_string(::getpid()) + (made++ ? "-" + std::to_string(made) : "") + ".sock";
    endpoint->listen(uds, ip + ":0");
    endpoint->set_gated(opts.gated || (opts.clock == ClockKind::Simulated && !opts.world.empty()));
    endpoint->set_clock(opts.stamp_clock ? opts.stamp_clock : [this] { return timers->now(); });
  } catch (const std::exception& e) {
    return fail_start(done_fn, e.what());
  }
  endpoint->on_event([this](const CommsEvent& e) { forward(e); });
  if (opts.clock == ClockKind::Wall && (opts.rt.priority > 0 || opts.rt.cpu >= 0)) {
    auto c = opts.rt;
    c.who = opts.name + " on host " + host;
    rt = rt_for(c);
  }
  if (!opts.shared) {
    if (!add_leaf(opts.type, opts.name, opts.args, rt, &error)) return fail_start(done_fn, error);
    if (rt) start_rt(*rt);
    return enlist(done_fn);
  }
  if (rt) start_rt(*rt);
  open_crash_note();
  clear_note_on_external_signals();
  timers->on_enter = note_leaf;
  control = listen(channels, [this](const Channel::Ptr& ch, const Message& m) { handle_process(ch, m); }, &error);
  if (!control) return fail_start(done_fn, "cannot listen for control channels: " + error);
  enlist(done_fn);
}

// On simulated time the node subscribes to the clock before it registers: nobody can find it (to connect to
// it, or to restart what it replaces) before the clock master knows it, so the master forgets the counts of
// the links of a leaf it hosted before (a restart) before any link to the new process is counted.
void Node::Impl::enlist(const Done& done_fn) {
  if (opts.clock == ClockKind::Simulated && !opts.world.empty()) return subscribe(done_fn);
  register_node(done_fn);
}

// A control listener on the daemon's IP: each channel it accepts joins `set` (and leaves it when it closes);
// its messages go to `on`.
Listener::Ptr Node::Impl::listen(const Set& set, std::function<void(const Channel::Ptr&, const Message&)> on,
                                 std::string* error) {
  std::weak_ptr<std::set<Channel::Ptr>> ws = set;
  return Listener::listen(loop.io(), *Address::parse(ip + ":0"), chopts, [ws, on](Channel::Ptr ch) {
    auto members = ws.lock();
    if (!members) return ch->close("gone");
    members->insert(ch);
    std::weak_ptr<Channel> w = ch;
    ch->on_message([w, on](const Message& m) {
      if (auto s = w.lock()) on(s, m);
    });
    ch->on_close([ws, w](const std::string&) {
      auto s = w.lock();
      if (auto st = ws.lock(); s && st) st->erase(s);
    });
  }, error);
}

// Creates a leaf: its component (on the process's timers), its ports in the process's endpoint and its own
// control listener. nullptr, with *error, when the factory refuses or the listener fails.
Leaf* Node::Impl::add_leaf(const std::string& type, const std::string& name, const std::vector<std::string>& args,
                           RtHost* on, std::string* error) {
  if (find(name)) {
    *error = name + " is already hosted by this node";
    return nullptr;
  }
  auto leaf = std::make_shared<Leaf>();
  leaf->type = type;
  leaf->name = name;
  leaf->instance = ++instances;
  Leaf* l = leaf.get();
  try {
    leaf->component = factory(type, name, host, args, on ? on->timers() : *timers);
    leaf->ports = &leaf->component->ports();
    if (on) leaf->ports = &on->adopt(*leaf->component, [this, l](const ComponentEvent& e) { forward(*l, e); });
    leaf->on_rt = on != nullptr;
    leaf->rt = on;
    endpoint->add_component(name, *leaf->ports);
  } catch (const std::exception& e) {
    if (on && leaf->component) leaf->mirror = on->forget(*leaf->component);
    *error = e.what();
    return nullptr;
  }
  std::weak_ptr<Leaf> wl = leaf;
  l->control = listen(l->supervisors, [this, wl](const Channel::Ptr& ch, const Message& m) {
    if (auto x = wl.lock()) handle(*x, ch, m);
  }, error);
  if (!l->control) {
    if (l->on_rt) l->mirror = l->rt->forget(*l->component);
    endpoint->remove_component(name);
    *error = "cannot listen for control channels: " + *error;
    return nullptr;
  }
  if (!l->on_rt) l->component->on_event = [this, l](const ComponentEvent& e) { forward(*l, e); };
  leaves.emplace(name, leaf);
  tell_leaves();
  return l;
}

// Ends a leaf: Stop (actuators safe), its connections closed both ways, its control channels closed, its PATH
// unregistered. Its component is destroyed last, after the loop has let go of its channels.
void Node::Impl::remove_leaf(const std::string& name) {
  auto it = leaves.find(name);
  if (it == leaves.end()) return;
  std::shared_ptr<Leaf> leaf = it->second;
  leaves.erase(it);
  tell_leaves();
  if (leaf->on_rt) leaf->mirror = leaf->rt->forget(*leaf->component);  // halted, the thread paused
  else leaf->component->halt();
  if (endpoint) endpoint->remove_component(name);  // null once shut down (shutdown removed every leaf's)
  leaf->control->close();
  for (auto ch : std::set<Channel::Ptr>(*leaf->supervisors)) ch->close("leaf " + name + " removed");
  if (daemon && opts.shared)
    daemon->request({"unregister", 0, Value::map().set("name", name)}, std::chrono::milliseconds(opts.timeout_ms),
                    [](Response) {});
  boost::asio::post(loop.io(), [leaf] {});  // its channels' handlers may still be on the stack
}

// The endpoints a leaf (or a shared node itself, leaf = nullptr) registers with.
Value Node::Impl::endpoints(const Leaf* leaf) const {
  const auto loc = endpoint->location();
  Value e = Value::map()
                .set("host", host)
                .set("control", (leaf ? leaf->control : control)->address().str())
                .set("data_uds", loc.data_uds)
                .set("data_tcp", loc.data_tcp)
                .set("pid", static_cast<std::int64_t>(::getpid()));
  if (leaf) e.set("type", leaf->type);
  if (opts.shared) e.set("shared", leaf ? Value(process_name()) : Value(true));
  if (opts.shared && leaf) e.set("instance", static_cast<std::int64_t>(leaf->instance));
  return e;
}

// Tells a leaf's supervisors that its component finished or aborted (`now`: on this node's clock).
void Node::Impl::forward(Leaf& leaf, const ComponentEvent& e) {
  ++events[leaf.name];
  if (e.kind == ComponentEvent::Kind::Done)
    leaf.event({"done", 0,
                Value::map().set("name", leaf.name).set("now", timers->now()).set("value", value_from_msgpack(
                    {reinterpret_cast<const std::byte*>(e.value.data()), e.value.size()}))});
  else
    leaf.event({"aborted", 0, Value::map().set("name", leaf.name).set("now", timers->now()).set("reason", e.reason)});
}

// Tells the supervisors of the leaf concerned that a data link broke or a port overflowed.
void Node::Impl::forward(const CommsEvent& e) {
  const Leaf* leaf = find(e.component);
  if (!leaf) return;
  if (e.kind == CommsEvent::Kind::Broken)
    leaf->event({"broken", 0, Value::map().set("name", e.component).set("port", e.port).set("peer", e.peer)
                                  .set("set", e.set).set("reason", e.reason)});
  else
    leaf->event({"overflow", 0, Value::map().set("name", e.component).set("port", e.port).set("reason", e.reason)});
}

// Registers the one leaf's PATH (or the shared node's NAME#PID) with the daemon: the start is done.
void Node::Impl::register_node(const Done& done_fn) {
  const Leaf* leaf = opts.shared ? nullptr : find(opts.name);
  const std::string name = process_name();
  daemon->request({"register", 0, Value::map().set("name", name).set("endpoints", endpoints(leaf))},
                  std::chrono::milliseconds(opts.timeout_ms), [this, done_fn, name](Response r) {
                    if (!r.ok()) return fail_start(done_fn, "cannot register " + name + ": " + r.error);
                    done_fn("");
                  });
}

void Node::shutdown(const std::string& why) {
  auto& I = *impl_;
  if (I.done) return;
  I.done = true;
  for (auto& kv : I.rts) kv.second->stop();
  for (auto& [name, leaf] : I.leaves) {
    if (leaf->on_rt) leaf->mirror = leaf->rt->forget(*leaf->component);
    else leaf->component->halt();
  }
  for (auto& [name, leaf] : I.leaves) {
    if (I.endpoint) I.endpoint->remove_component(name);
    leaf->control->close();
    for (auto ch : std::set<Channel::Ptr>(*leaf->supervisors)) ch->close(why);
    leaf->supervisors->clear();
  }
  I.endpoint.reset();
  if (I.control) {
    I.control->close();
    if (I.timers) I.timers->on_enter = nullptr;
    if (g_crash_note) ::munmap(g_crash_note, kCrashNote);
    g_crash_note = nullptr;
    std::error_code ec;
    std::filesystem::remove(crash_note_path(::getpid()), ec);
  }
  if (I.master) {
    auto c = I.master;
    I.master.reset();
    c->send({"unclock", 0, Value::map()});  // leaving in order: not a lost node
    c->close(why);
  }
  for (auto ch : std::set<Channel::Ptr>(*I.channels)) ch->close(why);
  I.channels->clear();
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
// One subscription per process, whatever the number of leaves it hosts.
void Node::Impl::connect_master(const Address& address, const Done& done_fn) {
  Channel::connect(loop.io(), address, chopts, [this, done_fn](Channel::Ptr ch, const std::string& e) {
    if (done) return;
    const std::string who = opts.name + " (simulated clock)";
    if (!ch) return fail_start(done_fn, who + ": cannot reach the clock master '" + opts.world + "': " + e);
    master = ch;
    std::weak_ptr<Channel> w = ch;
    ch->on_message([this, w](const Message& m) {
      if (auto c = w.lock()) handle_process(c, m);
    });
    ch->on_close([this](const std::string& reason) {
      if (done || !master) return;
      std::fprintf(stderr, "dca node %s: the clock master '%s' closed its channel (%s): stopping\n",
                   opts.name.c_str(), opts.world.c_str(), reason.c_str());
      code = 1;
      master.reset();
      boost::asio::post(loop.io(), [this] { loop.stop(); });
    });
    ch->request({"clock", 0, Value::map().set("name", process_name())}, std::chrono::milliseconds(opts.timeout_ms),
                [this, done_fn, who](Response r) {
                  if (done) return;
                  if (!r.ok()) return fail_start(done_fn, who + ": the clock master refused the subscription: " + r.error);
                  const Nanos now = r.message.payload["now"].as_int(0);
                  if (now > timers->now()) timers->advance_to(now);
                  tell_leaves();
                  register_node(done_fn);
                });
  });
}

// code {}: the process a leaf's code runs in, and whether its package's file changed since the process loaded it.
Value Node::Impl::code_of(const Leaf& leaf) const {
  Value r = Value::map().set("pid", static_cast<std::int64_t>(::getpid()))
                .set("leaves", static_cast<std::int64_t>(leaves.size()));
  if (opts.shared) r.set("shared", opts.name + "#" + std::to_string(::getpid()));
  if (!leaf.package.empty()) {
    r.set("package", leaf.package);
    if (opts.package_changed) {
      if (std::string why = opts.package_changed(leaf.package, leaf.system_dir); !why.empty()) r.set("changed", why);
    }
  }
  return r;
}

Value Node::Impl::ports(const Leaf& leaf) const {
  Value ins = Value::array(), outs = Value::array(), links = Value::array();
  for (const auto& p : leaf.ports->inputs()) {
    auto v = spec_value(p->spec());
    v.set("samples", p->stats().samples).set("dropped", p->stats().dropped).set("rejected", p->stats().rejected);
    v.set("queued", static_cast<std::uint64_t>(p->queued())).set("capacity", static_cast<std::uint64_t>(p->capacity()));
    ins.array_ref().push_back(std::move(v));
  }
  for (const auto& p : leaf.ports->outputs()) {
    auto v = spec_value(p->spec());
    v.set("samples", p->stats().samples).set("rejected", p->stats().rejected);
    outs.array_ref().push_back(std::move(v));
  }
  for (const auto& l : endpoint->links()) {
    if (l.request.from != leaf.name) continue;
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
  for (const auto& l : leaf.on_rt ? leaf.rt->links(*leaf.component) : std::vector<RtHost::LinkInfo>{})
    links.array_ref().push_back(Value::map().set("out", l.out).set("to", l.to).set("in", l.in).set("set", l.set)
                                    .set("mode", "push").set("transport", "inprocess").set("active", l.active)
                                    .set("broken", false).set("sent", l.sent).set("skipped", l.skipped)
                                    .set("tx_dropped", std::int64_t{0}).set("bytes", std::int64_t{0})
                                    .set("rt", true));
  return Value::map().set("inputs", ins).set("outputs", outs).set("links", links)
      .set("accepted", static_cast<std::uint64_t>(endpoint->accepted()))
      .set("bytes_received", endpoint->bytes_received())
      .set("refused", endpoint->refused());
}

// The leaf's own timers (named by its PATH; a one-leaf node reports every timer of the process, as before).
Value Node::Impl::stats(const Leaf& leaf) const {
  const auto mine = [&](const std::string& name) { return !opts.shared || name == leaf.name; };
  Value ts = Value::array();
  for (const auto& s : timers->stats())
    if (mine(s.name))
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
    if (mine(s.name))
      iv.array_ref().push_back(Value::map()
                                   .set("name", s.name)
                                   .set("period_s", to_seconds(s.period))
                                   .set("clock", summary(s.clock))
                                   .set("wall", summary(s.wall)));
  Value r = Value::map().set("timers", ts).set("intervals", iv).set("clock", to_string(timers->kind()));
  if (leaf.on_rt) r.set("rt", rt_stats(leaf));
  return r;
}

// ------------------------------------------------------------------------------ the real-time thread ---

// Starts a real-time thread; its set-up's warning, if any, once on stderr, which reaches `dca run`'s output.
void Node::Impl::start_rt(RtHost& h) {
  if (const auto w = h.start(); !w.empty()) std::fprintf(stderr, "dca node: %s\n", w.c_str());
}

// The real-time thread of setting `c` (its priority and CPU), made on the first ask (not started).
RtHost* Node::Impl::rt_for(rt::RtConfig c) {
  auto& h = rts[{c.priority, c.cpu}];
  if (!h) h = std::make_unique<RtHost>(loop.io(), std::move(c));
  return h.get();
}

// A leaf on the real-time thread: its figures there (host/node_rt.h), read without a lock.
Value Node::Impl::rt_stats(const Leaf& leaf) const {
  const RtHost& h = *leaf.rt;
  const auto st = h.stats(*leaf.component).value_or(RtLeafStats{});
  // its quantiles, and the histogram's buckets that hold runs: [[upper edge in us, count], ...]
  auto summary = [](const rt::RtSummary& x, const std::vector<std::pair<std::int64_t, std::uint64_t>>& b) {
    Value buckets = Value::array();
    for (const auto& [upper, n] : b)
      buckets.array_ref().push_back(Value(Value::Array{Value(static_cast<double>(upper) / 1e3), Value(n)}));
    return Value::map().set("n", x.n).set("p50_us", x.p50_us).set("p99_us", x.p99_us).set("p999_us", x.p999_us)
        .set("max_us", x.max_us).set("buckets", std::move(buckets));
  };
  const auto c = h.contract();
  return Value::map()
      .set("thread", static_cast<std::int64_t>(h.thread_id()))
      .set("runs", st.runs)
      .set("overruns", st.overruns)
      .set("missed", st.missed)
      .set("period_s", to_seconds(st.period))
      .set("wake", summary(st.wake, st.wake_buckets))
      .set("exec", summary(st.exec, st.exec_buckets))
      .set("dropped", h.dropped())
      .set("contract", Value::map().set("allocations", c.allocations).set("locks", c.locks)
                           .set("page_faults", c.page_faults));
}

// init, run, stop and set_param of a leaf on the real-time thread: done there between two ticks, answered here.
bool Node::Impl::rt_control(Leaf& leaf, const Channel::Ptr& ch, const Message& m) {
  const auto& t = m.type;
  RtHost::Op op{};
  std::string a, b;
  if (t == "init") {
    op = RtHost::Op::Configure;
  } else if (t == "run") {
    op = RtHost::Op::Start;
    if (m.payload.find("init")) a = msgpack_from_value(m.payload["init"]);
  } else if (t == "stop") {
    op = RtHost::Op::Halt;
  } else {
    return false;  // set_param (there too: set_param), and the requests of the I/O thread
  }
  std::weak_ptr<Leaf> wl = leaves.at(leaf.name);
  leaf.rt->request(*leaf.component, op, std::move(a), std::move(b), [this, wl, ch, m](const std::string& error) {
    if (done || wl.expired()) return;
    if (!error.empty()) ch->reply_error(m, error);
    else ch->reply(m);
  });
  return true;
}

void Node::Impl::connect(Leaf& leaf, const Channel::Ptr& ch, const Message& m) {
  const auto& p = m.payload;
  ConnectRequest r;
  r.from = leaf.name;
  r.out = p["out"].as_string();
  r.to = p["to"].as_string();
  r.in = p["in"].as_string();
  r.set = p["set"].as_string();
  const std::string mode = p["mode"].is_nil() ? "push" : p["mode"].as_string();
  const auto md = mode_from(mode);
  if (!md) return void(ch->reply_error(m, "connect: mode must be push or pull, not '" + mode + "'"));
  r.mode = *md;
  r.queue = static_cast<std::uint32_t>(p["queue"].is_nil() ? 16 : std::max<std::int64_t>(1, p["queue"].as_int(16)));
  r.stamped = p["stamped"].as_bool();  // a tap's link (host/net/tap.h)
  if (r.out.empty() || r.to.empty() || r.in.empty())
    return void(ch->reply_error(m, "connect needs out, to and in"));
  const int timeout = opts.timeout_ms;
  auto finish = [this, ch, m, from = leaf.name](const std::string& error) {
    if (!endpoint) return;
    if (!error.empty()) return void(ch->reply_error(m, error));
    Value t = "";
    for (const auto& l : endpoint->links())
      if (l.request.from == from && l.request.out == m.payload["out"].as_string() &&
          l.request.to == m.payload["to"].as_string() && l.request.in == m.payload["in"].as_string() &&
          l.request.set == m.payload["set"].as_string())
        t = std::string(to_string(l.transport));
    ch->reply(m, Value::map().set("transport", t));
  };
  if (const Leaf* to = find(r.to); to && to->on_rt && leaf.on_rt && to->rt == leaf.rt && r.mode == Mode::Push &&
                                   !r.stamped) {
    std::string err;  // both on the real-time thread: the link stays there (host/node_rt.h)
    if (!leaf.rt->link(*leaf.component, r.out, *to->component, r.in, r.set, r.queue, &err)) return finish(err);
    return void(ch->reply(m, Value::map().set("transport", "inprocess")));
  }
  if (endpoint->component(r.to)) return endpoint->connect(r, {}, finish, timeout);
  daemon->request({"lookup", 0, Value::map().set("name", r.to).set("wait_ms", static_cast<std::int64_t>(timeout))},
                  std::chrono::milliseconds(timeout + 1000), [this, r, finish, timeout](Response resp) {
                    if (!endpoint) return;
                    if (!resp.ok()) return finish("connect: cannot find " + r.to + ": " + resp.error);
                    const auto& e = resp.message.payload["endpoints"];
                    Location loc{e["host"].as_string(), e["data_uds"].as_string(), e["data_tcp"].as_string(),
                                 static_cast<std::uint64_t>(e["instance"].as_int(0))};
                    if (loc.host.empty()) loc.host = resp.message.payload["host"].as_string();
                    endpoint->connect(r, loc, finish, timeout);
                  });
}

// pull {port, timeout_ms}: asks the input's pull connections for their latest sample and answers with it
// when it arrives (checked every millisecond), or an error at the deadline.
void Node::Impl::pull(Leaf& leaf, const Channel::Ptr& ch, const Message& m) {
  const auto& name = m.payload["port"].as_string();
  Input* in = leaf.ports->find_input(name);
  if (!in) return void(ch->reply_error(m, leaf.ports->no_such_input(leaf.name, name)));
  const std::uint64_t before = in->stats().samples;
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::milliseconds(m.payload["timeout_ms"].as_int(opts.timeout_ms));
  in->request();
  auto timer = std::make_shared<boost::asio::steady_timer>(loop.io());
  auto check = std::make_shared<std::function<void()>>();
  // The function holds itself weakly; each pending wait holds it strongly, so it is freed when the chain ends.
  // It holds the leaf weakly too: a leaf removed meanwhile answers nothing more (its channels are closed).
  std::weak_ptr<std::function<void()>> self = check;
  std::weak_ptr<Leaf> wl = leaves.at(leaf.name);
  *check = [this, ch, m, wl, in, before, deadline, timer, self, name] {
    auto l = wl.lock();
    if (done || !l) return;
    if (in->stats().samples > before)
      return void(ch->reply(m, Value::map().set("value", latest_value(*in)).set("count", in->stats().samples)));
    if (std::chrono::steady_clock::now() >= deadline)
      return void(ch->reply_error(m, "pull: no sample arrived at " + l->name + "." + name + " in time"));
    timer->expires_after(std::chrono::milliseconds(1));
    timer->async_wait([strong = self.lock()](const boost::system::error_code& ec) {
      if (!ec && strong) (*strong)();
    });
  };
  (*check)();
}

// read {port}: the latest sample of any port of the leaf.
void Node::Impl::read(Leaf& leaf, const Channel::Ptr& ch, const Message& m) {
  const auto& name = m.payload["port"].as_string();
  auto& ps = *leaf.ports;
  const Port* port = ps.find_output(name);
  if (!port) port = ps.find_input(name);
  if (!port) {
    std::string valid;
    for (const auto& o : ps.outputs()) valid += (valid.empty() ? "" : ", ") + o->name();
    for (const auto& i : ps.inputs()) valid += (valid.empty() ? "" : ", ") + i->name();
    return void(ch->reply_error(m, "no port '" + name + "' on " + leaf.name + "; ports are: " +
                                       (valid.empty() ? std::string("(none)") : valid)));
  }
  ch->reply(m, Value::map().set("value", latest_value(*port)).set("count", port->stats().samples));
}

// The life-cycle and data requests of one leaf; false for any other.
bool Node::Impl::handle_control(Leaf& leaf, const Channel::Ptr& ch, const Message& m) {
  const CrashScope scope(leaf.name);
  if (leaf.on_rt && rt_control(leaf, ch, m)) return true;
  const auto& t = m.type;
  const auto& p = m.payload;
  auto& c = *leaf.component;
  std::string err;
  if (t == "init") {
    if (!c.configure(&err)) ch->reply_error(m, err);
    else ch->reply(m);
  } else if (t == "run") {
    const std::string init = p.find("init") ? msgpack_from_value(p["init"]) : std::string();
    if (!c.start({reinterpret_cast<const std::byte*>(init.data()), init.size()}, &err)) ch->reply_error(m, err);
    else ch->reply(m);
  } else if (t == "stop") {
    c.halt();
    ch->reply(m);
  } else if (t == "connect") {
    connect(leaf, ch, m);
  } else if (t == "disconnect") {
    endpoint->disconnect_set(p["set"].as_string());
    for (auto& kv : rts) kv.second->unlink(p["set"].as_string());
    ch->reply(m);
  } else if (t == "activate" || t == "deactivate") {
    const auto& set = p["set"].as_string();
    if (set.empty()) return ch->reply_error(m, t + " needs a set"), true;
    if (t == "activate") endpoint->activate(set, leaf.name);  // this leaf's links only (host/net/endpoint.h)
    else endpoint->deactivate(set, leaf.name);
    if (leaf.on_rt) leaf.rt->activate(set, *leaf.component, t == "activate");
    if (set.rfind("tap:", 0) != 0) {  // a tap only looks: no part of the run's trace (host/net/tap.h)
      switches.push_back(leaf.name + " " + (t == "activate" ? "+" : "-") + set);
      if (switches.size() > 1000) switches.erase(switches.begin());
    }
    ch->reply(m);
  } else if (t == "read") {
    read(leaf, ch, m);
  } else if (t == "pull") {
    pull(leaf, ch, m);
  } else if (t == "ports") {
    ch->reply(m, ports(leaf));
  } else if (t == "stats") {
    ch->reply(m, stats(leaf));
  } else if (t == "code") {
    ch->reply(m, code_of(leaf));
  } else if (t == "set_param") {
    set_param(leaf, ch, m);
  } else {
    return false;
  }
  return true;
}

namespace {
// A parameter's value as a .dca argument is written: a string as it is, a number in the fewest digits that read
// back the same (as the supervisor writes a node's arguments), true/false; nothing for anything else.
std::optional<std::string> argument_text(const Value& v) {
  if (v.is_string()) return v.as_string();
  if (v.is_bool()) return std::string(v.as_bool() ? "true" : "false");
  if (v.is_int()) return std::to_string(v.as_int());
  if (!v.is_float()) return std::nullopt;
  char b[32];
  const auto r = std::to_chars(b, b + sizeof b, v.as_float());
  return std::string(b, r.ptr);
}
}  // namespace

// set_param {name, value}: a live parameter of the leaf changed (Component::set_parameter), here on the loop
// thread, so between two ticks; an accepted change is recorded for the trace, at the tick of the next advance
// (the first whose MainCalc sees it).
void Node::Impl::set_param(Leaf& leaf, const Channel::Ptr& ch, const Message& m) {
  const std::string& name = m.payload["name"].as_string();
  const auto text = argument_text(m.payload["value"]);
  if (name.empty() || !text)
    return void(ch->reply_error(m, "set_param needs a name and a value (a number, a string or a boolean)"));
  auto took = [this, ch, m, leaf_name = leaf.name, name, value = *text](const std::string& err) {
    if (done) return;
    if (!err.empty()) return void(ch->reply_error(m, err));
    params.push_back(leaf_name + " " + name + "=" + value);
    if (params.size() > 1000) params.erase(params.begin());
    ch->reply(m, Value::map().set("value", value));
  };
  if (leaf.on_rt) return leaf.rt->request(*leaf.component, RtHost::Op::SetParameter, name, *text, took);  // there
  std::string err;
  if (!leaf.component->set_parameter(name, *text, &err)) return took(err.empty() ? "refused" : err);
  took("");
}

// A request on a leaf's own control channel: its own requests, then the process's (advance; exit ends the
// leaf only in a shared node), then the hook (the world's clock master requests).
void Node::Impl::handle(Leaf& leaf, const Channel::Ptr& ch, const Message& m) {
  if (done || !find(leaf.name)) return void(ch->reply_error(m, "node " + leaf.name + " is stopping"));
  if (before_hook) before_hook(m);
  if (handle_control(leaf, ch, m)) return;
  if (m.type == "exit" && opts.shared) {
    ch->reply(m);
    boost::asio::post(loop.io(), [this, name = leaf.name] { remove_leaf(name); });
    return;
  }
  if (m.type == "advance" || m.type == "exit") return handle_process(ch, m);
  if (hook && hook(ch, m)) return;
  if (m.id == 0) {
    // an event this node has no use for (e.g. the world's `broken`/`overflow`, sent to every channel it
    // accepted, clock subscribers included): answering it as an error would close the channel
    return;
  }
  ch->reply_error(m, "unknown request '" + m.type + "' for node " + leaf.name);
}

// add {controller, name, args} on a shared node: a new leaf, registered under its PATH before the answer.
void Node::Impl::add(const Channel::Ptr& ch, const Message& m) {
  const auto& p = m.payload;
  std::vector<std::string> args;
  for (const auto& a : p["args"].as_array()) {
    if (!a.is_string()) return void(ch->reply_error(m, "add: args must be strings"));
    args.push_back(a.as_string());
  }
  const std::string name = p["name"].as_string();
  const std::string type = p["controller"].as_string();
  if (name.empty() || type.empty()) return void(ch->reply_error(m, "add needs a controller (type) and a name"));
  std::string err;
  if (const std::string pkg = p["package"].as_string(); !pkg.empty()) {
    // the folder of the .dca file, as `dca node --system-dir` takes it (host/exec.cpp): never relative to
    // wherever this node happens to run
    if (const std::string sys = p["system_dir"].as_string(); !sys.empty() && sys[0] != '/')
      return void(ch->reply_error(m, "add: system_dir '" + sys + "' is not absolute"));
    if (!opts.load_package) return void(ch->reply_error(m, "add: this node cannot load package '" + pkg + "'"));
    if (!opts.load_package(pkg, p["system_dir"].as_string(), &err)) return void(ch->reply_error(m, err));
  }
  // its group's rt { } ({priority, cpu}, on the wall clock): the real-time thread of that setting, shared with the
  // other leaves of the same setting (a whole host's shared node: docs/placement.md); else the node's own, if any
  RtHost* on = rt;
  if (const Value& r = p["rt"]; r.is_map() && opts.clock == ClockKind::Wall) {
    rt::RtConfig c = opts.rt;
    const auto bounded = [](std::int64_t x) { return static_cast<int>(std::clamp<std::int64_t>(x, -2, 100000)); };
    c.priority = bounded(r["priority"].as_int(0));
    c.cpu = bounded(r["cpu"].as_int(-1));
    c.who = name + " on host " + host;
    // an invalid setting (a CPU this host lacks) is one warning and not applied, as `dca node --rt-cpu` is
    if (const auto e = rt::check(c); !e.empty()) {
      std::fprintf(stderr, "dca node: %s\n", rt::warning(c, e + ": not applied").c_str());
    } else if (c.priority > 0 || c.cpu >= 0) {
      const bool fresh = rts.find({c.priority, c.cpu}) == rts.end();
      on = rt_for(c);
      if (fresh) start_rt(*on);
    }
  }
  Leaf* leaf = add_leaf(type, name, args, on, &err);
  if (!leaf) return void(ch->reply_error(m, err));
  leaf->package = p["package"].as_string();
  leaf->system_dir = p["system_dir"].as_string();
  const Value e = endpoints(leaf);
  daemon->request({"register", 0, Value::map().set("name", name).set("endpoints", e)},
                  std::chrono::milliseconds(opts.timeout_ms), [this, ch, m, name, e](Response r) {
                    // shutdown() closes the daemon channel last, which answers this request at once with an
                    // error: the node (endpoint included) is already gone, so there is nothing to undo.
                    if (done) return;
                    if (!r.ok()) {
                      remove_leaf(name);
                      return void(ch->reply_error(m, "cannot register " + name + ": " + r.error));
                    }
                    ch->reply(m, e);
                  });
}

// advance {t, expect, trace}: lock-step (docs/time.md), for every leaf at once. The samples the
// master counts in `expect` (link key -> samples its writer had sent by its last answer) are let into the
// inputs, waiting for those still on their way; later ones stay held. Then every timer due by t runs, what they
// wrote is flushed, and the answer says the next deadline, the events so far and the links whose counts moved.
void Node::Impl::advance(const Channel::Ptr& ch, const Message& m) {
  if (timers->kind() != ClockKind::Simulated)
    return void(ch->reply_error(m, "advance: node " + opts.name + " runs on the wall clock"));
  const auto& p = m.payload;
  const Nanos at = p["t"].as_int(-1);
  if (at < timers->now()) return void(ch->reply_error(m, "advance: t must be >= now (" + std::to_string(timers->now()) + ")"));
  // the counted samples in (waiting for those still in the sockets); the others stay held
  if (const auto late = take_expected(p["expect"]); !late.empty()) return void(ch->reply_error(m, late));
  if (done) return;
  timers->advance_to(at);
  // what the timers wrote is on its way before the answer (the master moves on at once): socket writes go
  // to the kernel at once for a socket's first frame of this turn; the later ones, and a backed-up socket's,
  // are queued, and the loop flushes them
  if (endpoint->sending()) loop.settle();
  if (done) return;
  ch->reply(m, advance_reply(p["trace"].as_bool()));
  // asked to, the node polls for its next advance instead of sleeping (docs/time.md, "Spinning")
  if (const auto spin = p["spin"].as_int(0); spin > 0)
    loop.spin_for(std::chrono::microseconds(std::min<std::int64_t>(spin, 100'000)));
}

Value Node::Impl::advance_reply(bool trace) {
  const auto next = timers->next_deadline();
  std::uint64_t total = 0;
  for (const auto& [name, n] : events) total += n;
  Value r = Value::map().set("now", timers->now()).set("next", next ? Value(*next) : Value()).set("ev", total);
  // the events per leaf and the leaves only when they changed (the master keeps them): less to encode and
  // decode on the round's path
  if (events != evs_told) {
    Value evs = Value::map();
    for (const auto& [name, n] : events) evs.set(name, n);
    r.set("evs", std::move(evs));
    evs_told = events;
  }
  if (!leaves_told) {
    Value names = Value::array();
    for (const auto& [name, leaf] : leaves) names.array_ref().push_back(Value(name));
    r.set("leaves", std::move(names));
    leaves_told = true;
  }
  if (auto sent = sent_changes(); !sent.as_map().empty()) r.set("sent", std::move(sent));
  if (trace) r.set("dig", digests());
  return r;
}

// Lets the expected samples in; waits (bounded by the start-up timeout) for those not yet arrived. "" or why
// not, naming the late writer.
std::string Node::Impl::take_expected(const Value& expect) {
  if (!expect.is_map()) return "";
  bool all = true;
  for (const auto& [key, n] : expect.as_map()) all = endpoint->release(key.as_string(), n.as_int(0)) && all;
  if (all) return "";
  auto arrived = [&] {
    if (done || !endpoint) return true;
    for (const auto& [key, n] : expect.as_map())
      if (!endpoint->release(key.as_string(), n.as_int(0))) return false;
    return true;
  };
  if (loop.run_until(arrived, std::chrono::milliseconds(opts.timeout_ms)) || done) return "";
  for (const auto& [k, n] : expect.as_map())
    if (const auto& key = k.as_string(); endpoint->received(key) < static_cast<std::uint64_t>(n.as_int(0)))
      return "advance: " + opts.name + " waited " + std::to_string(opts.timeout_ms) + " ms for sample " +
             std::to_string(n.as_int(0)) + " of " + key.substr(0, key.find('>')) + " (link " + key + "), got " +
             std::to_string(endpoint->received(key));
  return "";
}

// The links whose sent count moved since the last answer: {to = {key = sent}}.
Value Node::Impl::sent_changes() {
  std::map<std::string, Value> by_to;
  for (auto& c : endpoint->sent_counts()) {
    const auto [it, fresh] = last_sent.try_emplace(c.key, c.sent);
    if (!fresh && it->second == c.sent) continue;
    it->second = c.sent;
    by_to[c.to].set(c.key, c.sent);
  }
  Value out = Value::map();
  for (auto& [to, v] : by_to) out.set(to, std::move(v));
  return out;
}

// Trace: each output's samples and digest, the set switches and the live parameters changed since the last answer.
Value Node::Impl::digests() {
  Value d = Value::array();
  for (const auto& [name, leaf] : leaves)
    for (const auto& o : leaf->ports->outputs())
      d.array_ref().push_back(Value(Value::Array{Value(name + "." + o->name()), Value(o->stats().samples),
                                                 Value(std::to_string(o->digest())), latest_value(*o)}));
  Value sw = Value::array();
  for (auto& x : switches) sw.array_ref().push_back(Value(x));
  switches.clear();
  Value par = Value::array();
  for (auto& x : params) par.array_ref().push_back(Value(x));
  params.clear();
  return Value::map().set("out", d).set("sw", sw).set("par", par);
}

Value Node::sent_changes() { return impl_->endpoint ? impl_->sent_changes() : Value::map(); }
std::string Node::take_expected(const Value& expect) { return impl_->endpoint ? impl_->take_expected(expect) : ""; }
Value Node::digests() { return impl_->endpoint ? impl_->digests() : Value::map(); }
void Node::hold_sends(std::function<bool(const std::string& to)> hold) {
  if (impl_->endpoint) impl_->endpoint->set_hold(std::move(hold));
}
void Node::release_sends(const std::vector<std::string>& to) {
  if (impl_->endpoint) impl_->endpoint->release_held(to);
}

// A request to the process: on the clock master's channel, a shared node's own control channel, or passed on
// from a leaf's channel (advance, exit).
void Node::Impl::handle_process(const Channel::Ptr& ch, const Message& m) {
  if (done) return void(ch->reply_error(m, "node " + opts.name + " is stopping"));
  if (m.type == "advance") return advance(ch, m);
  if (m.type == "exit") {
    ch->reply(m);
    boost::asio::post(loop.io(), [this] { loop.stop(); });  // the caller of run() then calls shutdown()
    return;
  }
  if (opts.shared && m.type == "add") return add(ch, m);
  if (opts.shared && m.type == "remove") {
    const std::string name = m.payload["name"].as_string();
    if (!find(name)) return void(ch->reply_error(m, "remove: " + name + " is not hosted by node " + process_name()));
    remove_leaf(name);
    return void(ch->reply(m));
  }
  if (hook && hook(ch, m)) return;
  if (m.id == 0) return;  // an event this node has no use for (see handle)
  ch->reply_error(m, "unknown request '" + m.type + "' for node " + process_name());
}

}  // namespace dca
