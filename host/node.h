#pragma once
// The node runtime (`dca node`): hosts components (controllers, "leaves") in one process. By default one leaf per
// process, so a crash is contained; a shared node (`--shared NAME`) hosts the leaves its supervisors add, which
// then exchange samples in process and take one lock-step advance per tick between them
// (docs/placement.md).
//
//   dca node --type T --name PATH --daemon ADDR [--key FILE] [--host NAME] [--clock wall|sim] [-- ARG...]
//   dca node --shared NAME --daemon ADDR [--key FILE] [--host NAME] [--clock wall|sim]
//
// Start-up: connects to its daemon (authenticated channel), learns the host name (`ping`) unless --host gives
// it, creates the component (ARG are the .dca arguments after the host), listens for data connections (a Unix
// socket under $XDG_RUNTIME_DIR or /tmp, and TCP on the daemon's IP) and for control channels (TCP on the
// daemon's IP), then registers PATH with the daemon:
//   register {name = PATH, endpoints = {host, control, data_uds, data_tcp, pid, type}}
// and waits, inactive. When the daemon's channel closes, the node stops its component and exits.
// A start that fails once the daemon's channel is open tells the daemon why before the node exits:
//   failed {pid, reason}  (answered ok) -> the daemon's exit event of this process carries `reason`
// so the supervisor learns the reason with the exit, at once (docs/processes.md, "Errors surface").
//
// Control requests (from its supervisor, on a channel to `control`), each answered ok or error {reason}:
//   init {}                                   -> ok {}
//   run {init}                                -> ok {}         init: the initial value (nil outside bindings)
//   stop {}                                   -> ok {}
//   connect {out, to, in, set, mode, queue, stamped}
//                                             -> ok {transport = "inprocess"|"unix"|"tcp"}
//                                                to: the destination's PATH, looked up at the daemon (peers
//                                                included); mode "push" (default) or "pull"; queue default 16;
//                                                stamped: a tap's link (host/net/tap.h; its set "tap:...", whose
//                                                switches the trace leaves out)
//   disconnect {set}                          -> ok {}
//   activate {set} / deactivate {set}         -> ok {}         a flag flip, never a socket opened or closed
//   read {port}                               -> ok {value, count}  the latest sample of any port (nil before)
//   set_param {name, value}                   -> ok {value}    a live parameter changed between two ticks
//                                                (Component::set_parameter; value: a number, string or boolean,
//                                                answered as the text the controller took); refused naming why
//   pull {port, timeout_ms}                   -> ok {value, count}  asks the input's pull connections for
//                                                their latest sample; answers when it has arrived
//   ports {}                                  -> ok {inputs = [...], outputs = [...], links = [...]} with
//                                                counters (samples, dropped, queued, rejected, skipped, sent),
//                                                accepted, bytes_received, refused (data connections refused
//                                                before their hello: no or a wrong key, deadline, bad hello)
//   stats {}                                  -> ok {timers = [{name, period_s, active, count, missed, p50_us,
//                                                p99_us, max_us}] (lateness), intervals = [{name, period_s,
//                                                clock = {n, p50_us, p99_us, p999_us, max_us, min_us, mean_us},
//                                                wall = {...}}] (the periods achieved: time between
//                                                consecutive MainCalc calls of each periodic timer, on the
//                                                node's clock and on the wall clock; host/timers.h), clock,
//                                                and for a leaf on the real-time thread (NodeOptions::rt) rt =
//                                                {thread, runs, overruns, missed, period_s, wake = {n, p50_us,
//                                                p99_us, p999_us, max_us}, exec = {...}, dropped, contract =
//                                                {allocations, locks, page_faults}} (host/node_rt.h; thread: its
//                                                kernel id; contract: counted on the thread since it started)
//   advance {t, expect, trace}  (--clock sim) -> ok {now, next, ev, evs, leaves, sent, dig}  t in ns;
//                                                lock-step (docs/time.md): expect = {link key = n}
//                                                the samples of each link into this node its writer had sent
//                                                by its last answer: they are let into the inputs (waiting
//                                                up to the timeout for late ones, then an error naming the
//                                                writer), later ones stay held; then every timer due by t
//                                                runs (host/timers.h) and what they wrote is flushed. next =
//                                                the next deadline (nil when none), ev = done/aborted events
//                                                sent so far (evs: per leaf), leaves = its leaves' PATHs,
//                                                sent = {to = {key = n}} the links whose counts moved, dig
//                                                (trace) = {out = [[port, n, digest, value]], sw = [sets],
//                                                par = ["PATH name=value"]: the live parameters changed}
//   code {}                                   -> ok {pid, leaves, shared, package, changed}: the process the
//                                                leaf's code runs in (shared: a shared node's NAME#PID, nil
//                                                in a one-leaf node; leaves: how many it hosts) and, for a
//                                                leaf added with a package, that package and why its file is no
//                                                longer what this process loaded (nil when it is:
//                                                NodeOptions::package_changed). A restart asks it first.
//   exit {}                                   -> ok {}, then the node stops its component and exits 0
// Leaves: each leaf has everything a one-leaf node has: its own control address (a listener of its own) taking
// every request above, its events (sent on its own control channels only), and its registration under its PATH
// (endpoints as above, with `shared` = the process's name when it lives in a shared node). Timers, the data
// endpoint (data_uds, data_tcp: one per process, so leaves of one process connect in process) and the
// clock subscription belong to the process. `ports` lists the leaf's ports and links (the counters accepted,
// bytes_received and refused are the process's); `stats` its own timers. `exit` on a leaf's channel ends the
// leaf (the process too when it is a one-leaf node). `disconnect {set}` removes the set's links of every leaf
// of the process (a set is the supervisor's, activated and removed at every source at once).
// A shared node (--shared NAME) registers NAME#PID (endpoints {host, control, data_uds, data_tcp, pid, shared =
// true}) and hosts no leaf at first; on its own control address it takes:
//   add {controller, name, args[, package, system_dir]} -> ok {control, ...} creates the leaf (controller: its
//                                                type; its package loaded first: NodeOptions::load_package),
//                                                registers its PATH and answers with its endpoints (with
//                                                `instance`: this process's count of adds, telling a leaf
//                                                added again from its old instance at the same address)
//   remove {name}                             -> ok {}   stops it (actuators safe), closes its connections and
//                                                control channels, unregisters its PATH; a later `add` of the
//                                                same PATH is a fresh instance (a restart)
//   advance {t}, exit {}                      as above, for the whole process
// A crash of the process ends every leaf it hosts (the supervisors learn it from the daemon's exit event). A
// shared node keeps in crash_note_path(pid) (a file mapped in memory) the PATH of the leaf whose code runs now
// (a timer callback, its MainCalc, or a control request its component handles; empty in between); when a
// signal ends the node, the daemon reads it and names that leaf in the exit event (`culprit`). A fatal signal
// sent from outside (kill -SEGV: si_code <= 0, another pid) names none, whichever leaf's code ran.
// Simulated time (--clock sim): before it registers, the node looks up the clock master (`world`, see --world)
// at its daemon, opens a channel to its control address and subscribes with `clock {name}` (answered ok {now}),
// so the master knows a new process of a leaf (a restart: its links' counts start afresh) before anybody can
// connect to it; it takes the master's time and from then on obeys its `advance {t}` requests (lock-step,
// docs/time.md). Periodic timers are aligned (host/timers.h set_aligned). If the master's channel closes, the node
// stops as it would on daemon loss. With --world none it subscribes to nothing and any control channel may
// advance it.
// Events it sends on every open control channel:
//   done {name, now, value}  aborted {name, now, reason} (now: ns on its clock)  broken {name, port, peer, set, reason}
//   overflow {name, port, reason}
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <dca/component.h>

#include "host/port.h"
#include "host/loop.h"
#include "host/rt/setup.h"
#include "host/timers.h"
#include "host/codec/wire.h"

namespace dca {

class Channel;

/// How a node is set up (the `dca node` command line).
struct NodeOptions {
  std::string type;                 ///< controller type (of the one leaf; "" for a shared node)
  std::string name;                 ///< instance PATH (a shared node: its name; it registers NAME#PID)
  bool shared = false;              ///< a shared node: leaves come with `add` requests
  std::string daemon;               ///< the daemon's address
  std::string key_file;             ///< cluster key file ("" = the default, see host/net/auth.h)
  std::string host;                 ///< logical host name ("" = ask the daemon)
  ClockKind clock = ClockKind::Wall;
  std::string world = "world";      ///< simulated clock: the clock master's name ("" = none)
  std::vector<std::string> args;    ///< the .dca arguments after the host
  int timeout_ms = 5000;            ///< for start-up steps and look-ups (and a late sample in lock-step)
  bool gated = false;               ///< lock-step delivery without a clock master of its own (the world)
  /// Real time (`--rt-priority`, `--rt-cpu`): with a priority > 0 or a CPU >= 0, on the wall clock, the leaves run
  /// on a real-time thread of the node's (host/node_rt.h); its set-up's one warning goes to stderr. Ignored on
  /// simulated time.
  rt::RtConfig rt;
  /// The time a tap's link stamps on each sample (host/net/tap.h); unset: the node's clock (its timers' now).
  std::function<std::int64_t()> stamp_clock;
  /// A shared node: loads the controller package an `add` names (package, system_dir) before creating its
  /// leaf; false with *error (`dca node` loads through controllers/packages.h). Unset: `add` with a package fails.
  std::function<bool(const std::string& package, const std::string& system_dir, std::string* error)> load_package;
  /// A shared node: why the package an `add` named (package, system_dir) is no longer the file this process
  /// loaded, "" when it is (the `code` request's `changed`; controllers/packages.h package_changed). Unset: "".
  std::function<std::string(const std::string& package, const std::string& system_dir)> package_changed;
};

/// Creates the hosted component: (type, name, host, args, timers). Throws std::invalid_argument with a message
/// for the supervisor (unknown type, bad parameter).
using ComponentFactory = std::function<std::unique_ptr<Component>(
    const std::string& type, const std::string& name, const std::string& host, const std::vector<std::string>& args,
    TimerServer& timers)>;

/// Where a shared node with process id `pid` notes the leaf whose code crashed (see above).
std::string crash_note_path(int pid);

/// msgpack bytes -> a wire value (nil for empty or malformed input).
wire::Value value_from_msgpack(Bytes b);
/// A wire value -> msgpack bytes.
std::string msgpack_from_value(const wire::Value& v);

/// The node runtime on a Loop.
class Node {
 public:
  Node(Loop& loop, NodeOptions options, ComponentFactory factory);
  ~Node();
  Node(const Node&) = delete;
  Node& operator=(const Node&) = delete;

  /// Starts up (see the header comment); `done(error)` runs once: "" when registered and ready.
  void start(std::function<void(const std::string& error)> done);
  /// Stops the component and closes everything (idempotent). Called on `exit`, SIGTERM, or daemon loss.
  void shutdown(const std::string& why);
  /// The leaves hosted now.
  std::size_t leaves() const;
  /// True once shutdown() ran.
  bool finished() const;
  /// The exit code to leave with (0, or 1 after a start-up failure or daemon loss).
  int exit_code() const;
  /// True when a failed start's reason reached the daemon (`failed`, see the header comment): it is in the
  /// daemon's log and goes to the supervisor with the exit event.
  bool failure_told() const;
  /// Extra control requests: `hook` sees every request the node does not know, before it would answer
  /// "unknown request"; it returns true when it handled (answered or will answer) it. The world process uses
  /// this for its clock master requests. Set before start().
  void on_request(std::function<bool(const std::shared_ptr<Channel>&, const wire::Message&)> hook);
  /// Called with each request on a leaf's control channel before the node handles it (the world writes its
  /// replayed samples due before a set changes: sim/device_node.h).
  void before_request(std::function<void(const wire::Message&)> hook);

  /// Lock-step, for the clock master's owner (the world, in this process): its links whose counts moved
  /// ({to = {key = sent}}), the expected samples let into its inputs ("" or why not), its outputs' digests
  /// (docs/time.md; NodeOptions::gated).
  wire::Value sent_changes();
  std::string take_expected(const wire::Value& expect);
  wire::Value digests();
  /// Endpoint::set_hold and Endpoint::release_held of its data endpoint (the world: its samples to a node go
  /// with that node's advance).
  void hold_sends(std::function<bool(const std::string& to)> hold);
  void release_sends(const std::vector<std::string>& to);

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace dca
