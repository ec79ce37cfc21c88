#pragma once
// The daemon's configuration service: the replica (host/config_store) served on the daemon's channels and
// replicated with the peer daemons (the same peers as the NameServer's).
//
// Requests (any authenticated channel to the daemon; docs/control-plane.md):
//   config_get {key}              -> ok {key, value, stamp = {ms, n, origin}, origin}
//                                    error "unknown key 'door.widht' (did you mean door.width?)"
//   config_set {values = {k = v}} -> ok {seq, stamp, origin, keys}   one transaction, acked after its commit
//   config_list {prefix?}         -> ok {entries = [{key, value, stamp, origin}...]}   sorted by key
//   config_log {n?}               -> ok {replica, path, version, transactions, txns = [{origin, seq, stamp,
//                                    writes = [{key, value}...]}...], conflicts = [{key, winner = {value, stamp},
//                                    loser = {value, stamp}, at_ms}...]}   newest first, n of each (default 20)
//   config_watch {prefix?}        -> ok {}; then events config_changed {key, value, stamp, origin, prefix} on that
//                                    channel for every change below prefix ("" = all), local or replicated
//   config_unwatch {prefix?}      -> ok {}
//   config_status {}              -> ok {replica, path, version, transactions, peers = [{address, connected,
//                                    error, syncs}]}
//   config_sync {replica, version} -> ok {replica, version, txns = [...], more}   (between daemons: the
//                                    transactions the asker lacks by its version vector, in stamp order, in
//                                    batches; an asker whose version shows what this side lacks is asked in turn)
//
// Replication: every sync_interval, and at once after a change, the service asks each peer (and each daemon
// that asked it) with config_sync. A peer that is unreachable, or whose request times out (a cut link), is
// closed and connected again at the next interval: a lost link is just retried.
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "host/loop.h"
#include "host/net/channel.h"
#include "host/config_store.h"

namespace dca {

/// How the configuration service is set up.
struct ConfigServiceOptions {
  std::string host = "localhost";              ///< the daemon's host name (in errors and the replica id)
  std::string state_dir;                       ///< the replica is <state_dir>/config.db (the dir is created)
  std::vector<Address> peers;                  ///< the daemons to replicate with
  ChannelOptions peer_options;                 ///< the cluster key for peer channels
  std::chrono::milliseconds sync_interval{2000};    ///< anti-entropy period (and reconnect period)
  std::chrono::milliseconds request_timeout{5000};  ///< a sync unanswered this long closes that peer's channel
  bool sync_full = true;                        ///< SQLite synchronous=FULL (else NORMAL)
  std::size_t batch = 2000;                     ///< transactions per sync reply at most
};

/// The configuration service of one daemon, on its io_context.
class ConfigService {
 public:
  /// Why start() failed.
  enum class StartError { kNone, kInUse, kFailed };

  ConfigService(boost::asio::io_context& io, ConfigServiceOptions options);
  ~ConfigService();
  ConfigService(const ConfigService&) = delete;
  ConfigService& operator=(const ConfigService&) = delete;

  /// Creates and locks the state directory (one daemon per directory), opens the replica (refusing a corrupt
  /// file, with its name) and starts replicating. kInUse when another process holds the directory.
  StartError start(std::string* error);
  /// Handles the config_* requests above; false for other types.
  bool handle(const Channel::Ptr& ch, const wire::Message& m);
  /// Stops replicating, closes the peer channels and the replica. Idempotent.
  void stop();

  /// The replica (nullptr before start or after stop).
  config::ConfigStore* store() { return store_.get(); }
  const std::string& path() const { return path_; }
  /// Completed sync exchanges so far (for tests).
  std::uint64_t syncs() const { return syncs_; }

 private:
  struct Partner;
  void tick();
  void connect(Partner& p);
  void sync_with(std::uint64_t id);
  void announce();
  void changed(const std::vector<config::Entry>& changes);
  Partner* partner_for(const Channel::Ptr& ch);
  void on_sync(const Channel::Ptr& ch, const wire::Message& m);
  void on_get(const Channel::Ptr& ch, const wire::Message& m);
  void on_set(const Channel::Ptr& ch, const wire::Message& m);
  void on_list(const Channel::Ptr& ch, const wire::Message& m);
  void on_log(const Channel::Ptr& ch, const wire::Message& m);
  void on_watch(const Channel::Ptr& ch, const wire::Message& m);
  void on_status(const Channel::Ptr& ch, const wire::Message& m);
  bool read_prefix(const Channel::Ptr& ch, const wire::Message& m, std::string& prefix);
  wire::Value summary() const;

  boost::asio::io_context& io_;
  ConfigServiceOptions options_;
  std::string path_;
  int lock_fd_ = -1;
  std::unique_ptr<config::ConfigStore> store_;
  std::map<std::uint64_t, std::unique_ptr<Partner>> partners_;
  std::uint64_t next_partner_ = 1;
  struct Watch {
    std::weak_ptr<Channel> ch;
    std::string prefix;
  };
  std::vector<Watch> watches_;
  std::unique_ptr<boost::asio::steady_timer> timer_;
  bool announce_pending_ = false;
  bool stopped_ = false;
  std::uint64_t syncs_ = 0;
  std::shared_ptr<int> alive_ = std::make_shared<int>(0);
};

}  // namespace dca
