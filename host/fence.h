#pragma once
// Fencing on a daemon (docs/supervision.md, "Fencing"): the leases of its requesters. A spawn (or a shared join)
// that carries `fence = SECONDS` ties its child to the lease of the channel that asked; every `ping` and every
// such spawn on that channel renews the lease, on this host's monotonic clock (no clock is compared with another
// host's). When the channel has been silent `fence` seconds, or closes, its children are fenced: SIGTERM (a node
// halts, which writes zero to its actuator outputs, and exits; a supervisor stops its subtree), then SIGKILL
// `kill_after` seconds later to one that lives on. Its supervisor waits `fence + margin` from the last renewal it
// sent before a standby takes over. A child several leases hold (a shared node joined by several supervisors) is
// fenced with the last of them.
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>

#include "host/loop.h"  // before any other Asio header
#include "host/exec.h"

namespace dca {

/// The leases of one daemon's requesters, keyed by channel (an identity: never dereferenced).
class Leases {
 public:
  /// Says why a child was fenced (its exit event carries the text as `reason`).
  using FencedFn = std::function<void(Executer::ChildId, const std::string& why)>;

  Leases(boost::asio::io_context& io, Executer& exec, std::string host);
  Leases(const Leases&) = delete;
  Leases& operator=(const Leases&) = delete;

  /// Child `id` (named `name`) is fenced with the lease of `channel` (its peer `peer`, for the log): renews it;
  /// the lease's time is the smallest `fence` granted on it. kill_after: SIGTERM -> SIGKILL (seconds).
  void grant(const void* channel, const std::string& peer, Executer::ChildId id, const std::string& name,
             double fence, double kill_after);
  /// A renewal on `channel` (a ping): its lease starts again from now. Nothing for a channel without one.
  void renew(const void* channel);
  /// `channel` closed: its children are fenced at once.
  void closed(const void* channel);
  /// Child `id` ended: forgotten.
  void exited(Executer::ChildId id);
  /// Seconds since `channel`'s last renewal (for tests and the log); negative without a lease.
  double silent_for(const void* channel) const;

  FencedFn on_fenced;

 private:
  struct Lease {
    std::string peer;
    double fence = 0, kill_after = 0;
    std::chrono::steady_clock::time_point renewed;
    std::unique_ptr<boost::asio::steady_timer> timer;
    std::map<Executer::ChildId, std::string> children;
  };
  void arm(const void* channel, Lease& l);
  void fence(const void* channel, const std::string& why);

  boost::asio::io_context& io_;
  Executer& exec_;
  std::string host_;
  std::map<const void*, Lease> leases_;
  std::map<Executer::ChildId, std::unique_ptr<boost::asio::steady_timer>> kills_;  // SIGKILL after SIGTERM
};

}  // namespace dca
