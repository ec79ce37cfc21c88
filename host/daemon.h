#pragma once
// The per-host daemon (`dca daemon`): a channel listener serving the Executer and the NameServer.
//
// Requests it answers on any authenticated channel (docs/control-plane.md):
//   spawn {argv, name?}        -> ok {child, pid}; later the event exit {child, pid, name, code | signal,
//                                 reason?} goes to the channel that asked (signal is a name such as "SIGSEGV";
//                                 reason: what the child said with `failed`, below)
//   spawn {argv, name, shared = true} -> ok {child, pid, joined}: a process several requesters share (a shared
//                                 node, host/node.h): while a child spawned so under `name` runs and is held,
//                                 the request joins it (joined = true, argv unused) instead of starting another;
//                                 every holder gets its exit event, with `culprit` = the leaf whose code ran when
//                                 a fatal signal ended it (the node's crash note, host/node.h), if it noted one
//   spawn {..., fence = S, kill_after = K} the child is fenced (host/fence.h): it is sent SIGTERM once this
//                                 channel has been silent S seconds (no ping, no spawn) or has closed, SIGKILL K
//                                 seconds later (default S / 4) if it lives on; its exit event's reason says so.
//                                 S and K: positive seconds up to 3600. A shared join takes them the same way
//   release {child}            -> ok {}            the requester no longer holds a shared child; when nobody
//                                                   does (releases, or holders' channels closed), it is sent
//                                                   SIGTERM and a later shared spawn of its name starts anew
//   kill {child, signal?}      -> ok {}            signal "SIGTERM" (default), "KILL", 9, ...; may also be sent
//                                                   as an event (id 0): no reply, errors go to stderr
//   register {name, endpoints} -> ok {name, host}  removed when the registering channel closes
//   unregister {name}          -> ok {}
//   lookup {name, wait_ms?}    -> ok {name, endpoints, host}, or error at the deadline (see host/names.h)
//   failed {pid, reason}       -> ok {}            a child (`dca node`) that failed before it was ready says why;
//                                                   its exit event then carries `reason` (host/node.h)
//   ping {}                    -> ok {host, pid}   also renews this channel's lease (spawn's `fence`)
//   status {}                  -> ok {host, children = [{child, pid, name}], names = [...]}
//   config_* {...}             the configuration repository (host/config_service.h has the full list): get, set,
//                                 list, log, watch (config_changed events), status, and config_sync between
//                                 daemons; with no state_dir: error "no configuration repository ..."
//   package_* {...}            the package store of rolling upgrades (host/package_store.h): install, rollback,
//                                 status; kept in <state_dir>/packages, beside the configuration replica
// Events besides exit: output {child, pid, name, host, line} for each line a child writes to its stderr (also
// written to the daemon's own stderr, its log), sent to its requester (a shared child's: its first holder);
// past the budget (kOutputBurst lines, kOutputRate a second, kOutputBacklog bytes queued on the channel) lines
// are left out and counted: output {child, pid, name, host, dropped = N} says how many, before the next line
// sent and before the exit event.
// Anything else goes to the handler set with on_message (other services, e.g. a TimerServer), else gets
// error "unknown request".
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "host/loop.h"
#include "host/net/channel.h"
#include "host/config_service.h"
#include "host/exec.h"
#include "host/fence.h"
#include "host/names.h"
#include "host/package_store.h"

namespace dca {

/// The budget of the stderr lines a daemon forwards per child (see the header comment).
inline constexpr double kOutputBurst = 1000, kOutputRate = 1000;
inline constexpr std::size_t kOutputBacklog = 1 << 20;

/// How a daemon is set up.
struct DaemonOptions {
  std::string host = "localhost";                      ///< this host's logical name
  Address listen = *Address::parse("127.0.0.1:0");     ///< where to listen (port 0: a free port)
  std::vector<Address> peers;                          ///< the other daemons, for name look-ups
  auth::Key key;                                       ///< the cluster key
  AllowList allow = AllowList::defaults();             ///< what spawn may start
  std::chrono::milliseconds stop_grace{2000};          ///< SIGTERM -> SIGKILL delay for children at stop
  std::chrono::milliseconds handshake_timeout{5000};   ///< for accepted and peer channels
  bool sim_clock = false;  ///< `--clock sim`: every `dca node` it spawns without --clock gets `--clock sim`
  /// Where the configuration replica lives (<state_dir>/config.db, replicated with `peers`); "" = none.
  std::string state_dir;
  /// The state_dir was not chosen by the user: when another daemon holds it, run without a repository (and say
  /// so on stderr and in every config_* reply) instead of refusing to start.
  bool state_dir_is_default = false;
  std::chrono::milliseconds config_sync_interval{2000};  ///< anti-entropy period with the peers
};

/// One host's daemon on an io_context.
class Daemon {
 public:
  /// Extra request handler: return true when it handled `m` (replied or will reply).
  using Handler = std::function<bool(const Channel::Ptr&, const wire::Message&)>;

  Daemon(boost::asio::io_context& io, DaemonOptions options);
  /// Calls stop().
  ~Daemon();
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  /// Binds and starts listening. False with *error when it cannot.
  bool start(std::string* error);
  /// Where it listens (with the chosen port), valid after start().
  const Address& address() const;
  /// Stops: no new connections, every child's process group killed and reaped (SIGTERM, then SIGKILL after
  /// stop_grace), pending look-ups failed, every channel closed. Idempotent; blocks at most about stop_grace.
  void stop();

  /// Handler for request types the daemon does not know.
  void on_message(Handler h) { extra_ = std::move(h); }
  /// Called with each refused connection's reason (default: printed on stderr).
  void on_refused(std::function<void(const std::string&)> fn) { on_refused_ = std::move(fn); }

  const std::string& host() const { return options_.host; }
  Executer& executer() { return exec_; }
  NameServer& names() { return names_; }
  /// The configuration service (nullptr when the daemon runs without a repository).
  ConfigService* config() { return config_.get(); }
  /// Open client channels.
  std::size_t channels() const { return channels_.size(); }

 private:
  void accepted(const Channel::Ptr& ch);
  void handle(const Channel::Ptr& ch, const wire::Message& m);
  void spawn(const Channel::Ptr& ch, const wire::Message& m);
  bool join(const Channel::Ptr& ch, const wire::Message& m, const std::string& name);
  bool fence_of(const Channel::Ptr& ch, const wire::Message& m, double* fence, double* kill_after);
  void release(Channel* holder, Executer::ChildId id);
  void failed(const Channel::Ptr& ch, const wire::Message& m);
  void output(Executer::ChildId id, const std::string& line);
  void tell_dropped(Executer::ChildId id, const Channel::Ptr& to);
  Channel::Ptr output_channel(Executer::ChildId id);
  void exited(Executer::ChildId id, const std::string& name, const std::weak_ptr<Channel>& requester,
              const ExitStatus& s);

  // A shared child: its pid and the channels that hold it (by address; a closed channel releases).
  struct Shared {
    std::string name;
    int pid = 0;
    std::map<Channel*, std::weak_ptr<Channel>> holders;
  };

  boost::asio::io_context& io_;
  DaemonOptions options_;
  Executer exec_;
  Leases leases_;
  NameServer names_;
  Listener::Ptr listener_;
  std::set<Channel::Ptr> channels_;
  std::map<Executer::ChildId, std::string> child_names_;
  std::map<Executer::ChildId, std::string> reasons_;    // why a child failed before it was ready (`failed`)
  // Where a child's stderr lines go (its requester), and their budget: a token bucket of lines, the lines left
  // out since the last one sent (docs/processes.md, "Output").
  struct Output {
    std::weak_ptr<Channel> to;
    std::string name;
    int pid = 0;
    double tokens = 0;
    std::chrono::steady_clock::time_point at;
    std::uint64_t dropped = 0;
  };
  std::map<Executer::ChildId, Output> outputs_;
  std::map<Executer::ChildId, Shared> shared_;          // shared children (held or not yet exited)
  std::map<std::string, Executer::ChildId> shared_by_name_;  // the held ones a shared spawn joins
  std::unique_ptr<ConfigService> config_;
  std::string config_off_;  // why there is no repository
  std::unique_ptr<PackageStore> packages_;
  Handler extra_;
  std::function<void(const std::string&)> on_refused_;
  bool stopped_ = false;
};

}  // namespace dca
