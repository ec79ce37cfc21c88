#pragma once
// The NameServer: name -> endpoints, one per daemon, answering for its peers' names too.
//
// NameTable is the pure part (no I/O, no clock): names, their owners, and who waits for a name.
// NameServer is the thin Asio shell the daemon uses: it answers `register {name, endpoints}`,
// `unregister {name}` and `lookup {name, wait_ms}` on its channels (docs/control-plane.md).
// A lookup of a name not registered here is asked of every peer daemon (as `lookup {name, wait_ms,
// local_only = true}`, so peers never forward it again); the first positive answer wins. With wait_ms > 0 a
// lookup waits that long for the name to be registered (here or at a peer) before it fails.
// Replies to lookup: `ok {name, endpoints, host}` where host is the host name of the daemon that holds it.
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "host/codec/wire.h"
#include "host/net/channel.h"

namespace dca {

/// The pure name table.
class NameTable {
 public:
  using Owner = std::uint64_t;   ///< who registered a name (the daemon uses one id per channel)
  using Waiter = std::uint64_t;  ///< a pending lookup

  struct Entry {
    wire::Value endpoints;  ///< whatever the registrant gave (a map: host, control, data_uds, pid, ...)
    Owner owner = 0;
  };

  /// Registers `name`. The same owner may register a name again (its endpoints are replaced); another owner's
  /// name is refused with *error ("name 'x' is already registered"). Names are 1 to 1024 bytes.
  bool add(const std::string& name, wire::Value endpoints, Owner owner, std::string* error);
  /// The entry of `name`, or nullptr.
  const Entry* find(const std::string& name) const;
  /// Removes `name` if `owner` registered it; false with *error otherwise.
  bool remove(const std::string& name, Owner owner, std::string* error);
  /// Removes every name `owner` registered (when its channel closes); returns them.
  std::vector<std::string> remove_owner(Owner owner);

  /// Records that `w` waits for `name`.
  void wait(const std::string& name, Waiter w);
  /// Forgets waiter `w` (answered elsewhere, or timed out).
  void cancel_wait(Waiter w);
  /// The waiters for `name` (in the order they began waiting), forgotten by the table.
  std::vector<Waiter> take_waiters(const std::string& name);
  /// How many lookups wait.
  std::size_t waiting() const { return waiter_names_.size(); }

  /// Every registered name, sorted.
  std::vector<std::string> names() const;
  std::size_t size() const { return entries_.size(); }

 private:
  std::map<std::string, Entry> entries_;
  std::multimap<std::string, Waiter> waiters_;
  std::map<Waiter, std::string> waiter_names_;
};

/// The daemon's NameServer: the table, plus look-ups at peer daemons. Runs on one io_context.
class NameServer {
 public:
  /// `host` names this daemon in replies; `peers` are the other daemons' addresses, reached with `peer_options`
  /// (the cluster key) on first need and kept open.
  NameServer(boost::asio::io_context& io, std::string host, std::vector<Address> peers, ChannelOptions peer_options);
  ~NameServer();
  NameServer(const NameServer&) = delete;
  NameServer& operator=(const NameServer&) = delete;

  /// Handles `register`, `unregister` and `lookup` requests arriving on `ch`; returns false for other types.
  bool handle(const Channel::Ptr& ch, const wire::Message& m);
  /// Unregisters every name `ch` registered (call when it closes).
  void channel_closed(const Channel* ch);
  /// Fails every waiting lookup and closes the peer channels.
  void stop();

  const NameTable& table() const { return table_; }

 private:
  struct Lookup;
  struct Peer;
  void lookup(const Channel::Ptr& ch, const wire::Message& m);
  void finish(const std::shared_ptr<Lookup>& l, const wire::Message* found, const std::string& error);
  void ask_peer(std::size_t i, const std::shared_ptr<Lookup>& l);
  void with_peer(std::size_t i, std::function<void(Channel::Ptr, const std::string&)> fn);

  boost::asio::io_context& io_;
  std::string host_;
  ChannelOptions peer_options_;
  NameTable table_;
  std::vector<std::unique_ptr<Peer>> peers_;
  std::map<NameTable::Waiter, std::shared_ptr<Lookup>> lookups_;
  NameTable::Waiter next_waiter_ = 1;
  bool stopped_ = false;
  std::shared_ptr<int> alive_ = std::make_shared<int>(0);  // weak copies tell late callbacks we are gone
};

}  // namespace dca
