#include "host/config_service.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <boost/asio/post.hpp>
#include <cerrno>
#include <cstring>
#include <filesystem>

namespace dca {
namespace asio = boost::asio;
using config::Entry;
using config::Stamp;
using config::Txn;
using wire::Value;

struct ConfigService::Partner {
  std::uint64_t id = 0;
  bool outbound = false;     // one of options_.peers (connected and reconnected by this side)
  Address address;           // outbound only
  Channel::Ptr ch;           // outbound: owned here
  std::weak_ptr<Channel> in; // inbound: a daemon that asked us (the channel is the Daemon's)
  bool connecting = false, in_flight = false, again = false;
  std::string error;
  std::uint64_t syncs = 0;
  Channel::Ptr channel() const { return outbound ? ch : in.lock(); }
};

namespace {

Value entry_value(const Entry& e) {
  return Value::map().set("key", e.key).set("value", e.value).set("stamp", e.stamp.value()).set("origin", e.stamp.origin);
}

bool under(const std::string& key, const std::string& prefix) {
  return prefix.empty() || key == prefix || (key.size() > prefix.size() && key.compare(0, prefix.size(), prefix) == 0 &&
                                             key[prefix.size()] == '.');
}

std::string trim_prefix(std::string p) {
  while (!p.empty() && p.back() == '.') p.pop_back();
  return p;
}

}  // namespace

ConfigService::ConfigService(asio::io_context& io, ConfigServiceOptions options)
    : io_(io), options_(std::move(options)) {}

ConfigService::~ConfigService() { stop(); }

ConfigService::StartError ConfigService::start(std::string* error) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(options_.state_dir, ec);
  if (ec) {
    *error = "cannot create the state directory " + options_.state_dir + ": " + ec.message();
    return StartError::kFailed;
  }
  const std::string lock = (fs::path(options_.state_dir) / "lock").string();
  lock_fd_ = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
  if (lock_fd_ < 0) {
    *error = "cannot open " + lock + ": " + std::strerror(errno);
    return StartError::kFailed;
  }
  if (::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
    char buf[32] = {};
    const auto n = ::pread(lock_fd_, buf, sizeof buf - 1, 0);
    *error = "the state directory " + options_.state_dir + " is in use by another daemon" +
             (n > 0 ? " (pid " + std::string(buf, static_cast<std::size_t>(n)) + ")" : std::string()) +
             "; give each daemon its own --state-dir";
    ::close(lock_fd_);
    lock_fd_ = -1;
    return StartError::kInUse;
  }
  const std::string pid = std::to_string(::getpid());
  if (::ftruncate(lock_fd_, 0) != 0 || ::pwrite(lock_fd_, pid.data(), pid.size(), 0) < 0) {
    // the pid is only for the message above; the lock is what counts
  }
  path_ = (fs::path(options_.state_dir) / "config.db").string();
  config::StoreOptions so;
  so.path = path_;
  so.host = options_.host;
  so.sync_full = options_.sync_full;
  store_ = config::ConfigStore::open(so, error);
  if (!store_) {
    ::close(lock_fd_);
    lock_fd_ = -1;
    return StartError::kFailed;
  }
  for (const auto& a : options_.peers) {
    auto p = std::make_unique<Partner>();
    p->id = next_partner_++;
    p->outbound = true;
    p->address = a;
    partners_[p->id] = std::move(p);
  }
  timer_ = std::make_unique<asio::steady_timer>(io_);
  tick();
  return StartError::kNone;
}

void ConfigService::stop() {
  if (stopped_) return;
  stopped_ = true;
  if (timer_) timer_->cancel();
  for (auto& [id, p] : partners_)
    if (p->outbound && p->ch) p->ch->close("the configuration service on host " + options_.host + " stopped");
  partners_.clear();
  watches_.clear();
  store_.reset();
  if (lock_fd_ >= 0) ::close(lock_fd_);
  lock_fd_ = -1;
}

void ConfigService::tick() {
  if (stopped_) return;
  for (auto& [id, p] : partners_) {
    if (p->outbound && (!p->ch || !p->ch->is_open())) {
      connect(*p);
    } else {
      sync_with(id);
    }
  }
  // forget inbound partners whose channel closed
  for (auto it = partners_.begin(); it != partners_.end();) {
    if (!it->second->outbound && it->second->in.expired()) {
      it = partners_.erase(it);
    } else {
      ++it;
    }
  }
  timer_->expires_after(options_.sync_interval);
  timer_->async_wait([this, alive = std::weak_ptr<int>(alive_)](const boost::system::error_code& ec) {
    if (!ec && alive.lock()) tick();
  });
}

void ConfigService::connect(Partner& p) {
  if (p.connecting) return;
  p.connecting = true;
  const auto id = p.id;
  Channel::connect(io_, p.address, options_.peer_options,
                   [this, id, alive = std::weak_ptr<int>(alive_)](Channel::Ptr ch, const std::string& error) {
                     if (!alive.lock() || stopped_) {
                       if (ch) ch->close("the configuration service stopped");
                       return;
                     }
                     auto it = partners_.find(id);
                     if (it == partners_.end()) return;
                     Partner& q = *it->second;
                     q.connecting = false;
                     if (!ch) {
                       q.error = "unreachable: " + error;
                       return;
                     }
                     q.ch = ch;
                     q.error.clear();
                     q.in_flight = false;
                     std::weak_ptr<Channel> w = ch;
                     // The peer may ask this side on the same channel.
                     ch->on_message([this, w, alive](const wire::Message& m) {
                       auto c = w.lock();
                       if (!c || !alive.lock() || m.id == 0) return;
                       if (!handle(c, m)) c->reply_error(m, "a configuration peer channel answers config_* only");
                     });
                     ch->on_close([this, id, alive](const std::string& reason) {
                       if (!alive.lock()) return;
                       auto f = partners_.find(id);
                       if (f != partners_.end()) f->second->error = "closed: " + reason;
                     });
                     sync_with(id);
                   });
}

void ConfigService::sync_with(std::uint64_t id) {
  auto it = partners_.find(id);
  if (it == partners_.end() || stopped_) return;
  Partner& p = *it->second;
  auto ch = p.channel();
  if (!ch || !ch->is_open()) return;
  if (p.in_flight) {
    p.again = true;
    return;
  }
  p.in_flight = true;
  p.again = false;
  wire::Message m{"config_sync", 0,
                  Value::map().set("replica", store_->origin()).set("version", config::version_value(store_->version()))};
  ch->request(std::move(m), options_.request_timeout,
              [this, id, alive = std::weak_ptr<int>(alive_)](Response r) {
                if (!alive.lock() || stopped_) return;
                auto f = partners_.find(id);
                if (f == partners_.end()) return;
                Partner& q = *f->second;
                q.in_flight = false;
                if (!r.ok()) {
                  q.error = r.error;
                  // No answer at all (a cut link, a stopped daemon): drop the channel; the next tick reconnects.
                  if (!r.replied() && q.outbound && q.ch) q.ch->close("config sync: " + r.error);
                  return;
                }
                q.error.clear();
                ++q.syncs;
                ++syncs_;
                std::vector<Txn> txns;
                for (const auto& v : r.message.payload["txns"].as_array()) {
                  std::string why;
                  auto t = Txn::from_value(v, &why);
                  if (!t) {
                    q.error = "bad transaction from the peer: " + why;
                    return;
                  }
                  txns.push_back(std::move(*t));
                }
                std::vector<Entry> changes;
                std::string error;
                const auto applied = txns.empty() ? 0 : store_->apply(txns, &changes, &error);
                if (!error.empty()) q.error = "applying replicated transactions: " + error;
                if (applied > 0) {
                  changed(changes);
                  announce();
                }
                if ((r.message.payload["more"].as_bool() && applied > 0) || q.again) sync_with(id);
              });
}

void ConfigService::announce() {
  if (announce_pending_) return;
  announce_pending_ = true;
  asio::post(io_, [this, alive = std::weak_ptr<int>(alive_)] {
    if (!alive.lock() || stopped_) return;
    announce_pending_ = false;
    std::vector<std::uint64_t> ids;
    for (const auto& [id, p] : partners_) ids.push_back(id);
    for (auto id : ids) sync_with(id);
  });
}

void ConfigService::changed(const std::vector<Entry>& changes) {
  bool dead = false;
  for (const auto& e : changes) {
    for (const auto& w : watches_) {
      auto ch = w.ch.lock();
      if (!ch || !ch->is_open()) {
        dead = true;
        continue;
      }
      if (!under(e.key, w.prefix)) continue;
      ch->send(wire::Message{"config_changed", 0, entry_value(e).set("prefix", w.prefix)});
    }
  }
  if (dead) {
    std::erase_if(watches_, [](const Watch& w) {
      auto ch = w.ch.lock();
      return !ch || !ch->is_open();
    });
  }
}

ConfigService::Partner* ConfigService::partner_for(const Channel::Ptr& ch) {
  for (auto& [id, p] : partners_) {
    if (p->outbound ? p->ch == ch : p->in.lock() == ch) return p.get();
  }
  auto p = std::make_unique<Partner>();
  p->id = next_partner_++;
  p->in = ch;
  auto* raw = p.get();
  partners_[p->id] = std::move(p);
  return raw;
}

void ConfigService::on_sync(const Channel::Ptr& ch, const wire::Message& m) {
  const auto theirs = config::version_from_value(m.payload["version"]);
  if (!theirs || !m.payload["replica"].is_string()) {
    ch->reply_error(m, "config_sync needs {replica, version = {origin = seq...}}");
    return;
  }
  bool more = false;
  const auto txns = store_->missing(*theirs, options_.batch, 4u << 20, &more);
  Value::Array out;
  out.reserve(txns.size());
  for (const auto& t : txns) out.push_back(t.value());
  ch->reply(m, Value::map()
                   .set("replica", store_->origin())
                   .set("version", config::version_value(store_->version()))
                   .set("txns", Value(std::move(out)))
                   .set("more", more));
  if (m.payload["replica"].as_string() == store_->origin()) return;
  Partner* p = partner_for(ch);
  // They hold something this replica lacks: ask them in turn.
  if (store_->lacks_from(*theirs)) sync_with(p->id);
}

bool ConfigService::handle(const Channel::Ptr& ch, const wire::Message& m) {
  if (m.type.rfind("config_", 0) != 0) return false;
  if (!store_) {
    ch->reply_error(m, "the configuration service on host " + options_.host + " is stopped");
    return true;
  }
  using Handler = void (ConfigService::*)(const Channel::Ptr&, const wire::Message&);
  static const std::map<std::string, Handler> kHandlers = {
      {"config_sync", &ConfigService::on_sync},   {"config_get", &ConfigService::on_get},
      {"config_set", &ConfigService::on_set},     {"config_list", &ConfigService::on_list},
      {"config_log", &ConfigService::on_log},     {"config_watch", &ConfigService::on_watch},
      {"config_unwatch", &ConfigService::on_watch}, {"config_status", &ConfigService::on_status}};
  if (auto h = kHandlers.find(m.type); h != kHandlers.end()) {
    (this->*(h->second))(ch, m);
  } else {
    ch->reply_error(m, "unknown request '" + m.type +
                           "' (the configuration service on host " + options_.host +
                           " answers config_get, config_set, config_list, config_log, config_watch, config_unwatch, "
                           "config_status, config_sync)");
  }
  return true;
}

// config_get {key}: the entry.
void ConfigService::on_get(const Channel::Ptr& ch, const wire::Message& m) {
  if (!m.payload["key"].is_string()) return void(ch->reply_error(m, "config_get needs {key}"));
  std::string error;
  auto e = store_->get(m.payload["key"].as_string(), &error);
  if (!e) return void(ch->reply_error(m, error + " on host " + options_.host));
  ch->reply(m, entry_value(*e));
}

// config_set {values = {key = value...}}: one transaction; tells the watchers and the partners.
void ConfigService::on_set(const Channel::Ptr& ch, const wire::Message& m) {
  const auto& values = m.payload["values"];
  if (!values.is_map() || values.as_map().empty())
    return void(ch->reply_error(m, "config_set needs {values = {key = value...}} with at least one key"));
  std::vector<std::pair<std::string, Value>> kv;
  for (const auto& [k, v] : values.as_map()) {
    if (!k.is_string()) return void(ch->reply_error(m, "config_set: keys are strings, not " + k.str()));
    kv.emplace_back(k.as_string(), v);
  }
  std::vector<Entry> changes;
  std::string error;
  auto t = store_->set(kv, &changes, &error);
  if (!t) return void(ch->reply_error(m, error + " (host " + options_.host + ")"));
  ch->reply(m, Value::map()
                   .set("seq", static_cast<std::int64_t>(t->seq))
                   .set("stamp", t->stamp.value())
                   .set("origin", t->origin)
                   .set("keys", static_cast<std::int64_t>(t->writes.size())));
  changed(changes);
  announce();
}

// The request's {prefix}, trimmed, into `prefix`: false (after replying the error) when it is no valid key.
bool ConfigService::read_prefix(const Channel::Ptr& ch, const wire::Message& m, std::string& prefix) {
  prefix = trim_prefix(m.payload["prefix"].as_string());
  if (prefix.empty()) return true;
  if (std::string why; !config::valid_key(prefix, &why)) {
    ch->reply_error(m, why);
    return false;
  }
  return true;
}

// config_list {prefix}: the entries under prefix.
void ConfigService::on_list(const Channel::Ptr& ch, const wire::Message& m) {
  std::string prefix;
  if (!read_prefix(ch, m, prefix)) return;
  Value::Array entries;
  for (const auto& e : store_->list(prefix)) entries.push_back(entry_value(e));
  ch->reply(m, Value::map().set("entries", Value(std::move(entries))));
}

// config_log {n}: the n latest transactions and conflicts, with the replica's summary.
void ConfigService::on_log(const Channel::Ptr& ch, const wire::Message& m) {
  const auto n = static_cast<std::size_t>(std::clamp<std::int64_t>(m.payload["n"].as_int(20), 1, 10000));
  Value::Array txns, conflicts;
  for (const auto& t : store_->recent(n)) {
    Value::Array writes;
    for (const auto& w : t.writes) writes.push_back(Value::map().set("key", w.key).set("value", w.value));
    txns.push_back(Value::map()
                       .set("origin", t.origin)
                       .set("seq", static_cast<std::int64_t>(t.seq))
                       .set("stamp", t.stamp.value())
                       .set("writes", Value(std::move(writes))));
  }
  for (const auto& c : store_->conflicts(n)) {
    conflicts.push_back(Value::map()
                            .set("key", c.key)
                            .set("winner", Value::map().set("value", c.winner_value).set("stamp", c.winner.value()))
                            .set("loser", Value::map().set("value", c.loser_value).set("stamp", c.loser.value()))
                            .set("at_ms", c.at_ms));
  }
  ch->reply(m, summary().set("txns", Value(std::move(txns))).set("conflicts", Value(std::move(conflicts))));
}

// config_watch / config_unwatch {prefix}: (stop) sending this channel the changes under prefix.
void ConfigService::on_watch(const Channel::Ptr& ch, const wire::Message& m) {
  std::string prefix;
  if (!read_prefix(ch, m, prefix)) return;
  std::erase_if(watches_, [&](const Watch& w) { return w.prefix == prefix && w.ch.lock() == ch; });
  if (m.type == "config_watch") watches_.push_back(Watch{ch, prefix});
  ch->reply(m, Value::map().set("prefix", prefix));
}

// config_status: the replica's summary and its partners.
void ConfigService::on_status(const Channel::Ptr& ch, const wire::Message& m) {
  Value::Array peers;
  for (const auto& [id, q] : partners_) {
    auto c = q->channel();
    peers.push_back(Value::map()
                        .set("address", q->outbound ? q->address.str() : (c ? c->peer() : std::string("(gone)")))
                        .set("outbound", q->outbound)
                        .set("connected", c != nullptr && c->is_open())
                        .set("error", q->error)
                        .set("syncs", static_cast<std::int64_t>(q->syncs)));
  }
  ch->reply(m, summary().set("peers", Value(std::move(peers))));
}

// The replica, its host, its file, version and transaction count (config_log's and config_status's head).
wire::Value ConfigService::summary() const {
  return Value::map()
      .set("replica", store_->origin())
      .set("host", options_.host)
      .set("path", path_)
      .set("version", config::version_value(store_->version()))
      .set("transactions", static_cast<std::int64_t>(store_->transactions()));
}

}  // namespace dca
