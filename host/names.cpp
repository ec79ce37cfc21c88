#include "host/names.h"

#include <algorithm>

namespace dca {
namespace asio = boost::asio;
using namespace std::chrono_literals;

// ---------------------------------------------------------------------------------------------------- NameTable

bool NameTable::add(const std::string& name, wire::Value endpoints, Owner owner, std::string* error) {
  if (name.empty() || name.size() > 1024) {
    if (error != nullptr) *error = "a name must be 1 to 1024 bytes";
    return false;
  }
  auto it = entries_.find(name);
  if (it != entries_.end() && it->second.owner != owner) {
    if (error != nullptr) *error = "name '" + name + "' is already registered";
    return false;
  }
  entries_[name] = Entry{std::move(endpoints), owner};
  return true;
}

const NameTable::Entry* NameTable::find(const std::string& name) const {
  auto it = entries_.find(name);
  return it == entries_.end() ? nullptr : &it->second;
}

bool NameTable::remove(const std::string& name, Owner owner, std::string* error) {
  auto it = entries_.find(name);
  if (it == entries_.end()) {
    if (error != nullptr) *error = "name '" + name + "' is not registered";
    return false;
  }
  if (it->second.owner != owner) {
    if (error != nullptr) *error = "name '" + name + "' was registered by another process";
    return false;
  }
  entries_.erase(it);
  return true;
}

std::vector<std::string> NameTable::remove_owner(Owner owner) {
  std::vector<std::string> out;
  for (auto it = entries_.begin(); it != entries_.end();) {
    if (it->second.owner == owner) {
      out.push_back(it->first);
      it = entries_.erase(it);
    } else {
      ++it;
    }
  }
  return out;
}

void NameTable::wait(const std::string& name, Waiter w) {
  waiters_.emplace(name, w);
  waiter_names_[w] = name;
}

void NameTable::cancel_wait(Waiter w) {
  auto it = waiter_names_.find(w);
  if (it == waiter_names_.end()) return;
  auto [b, e] = waiters_.equal_range(it->second);
  for (auto i = b; i != e; ++i) {
    if (i->second == w) {
      waiters_.erase(i);
      break;
    }
  }
  waiter_names_.erase(it);
}

std::vector<NameTable::Waiter> NameTable::take_waiters(const std::string& name) {
  std::vector<Waiter> out;
  auto [b, e] = waiters_.equal_range(name);
  for (auto i = b; i != e; ++i) {
    out.push_back(i->second);
    waiter_names_.erase(i->second);
  }
  waiters_.erase(b, e);
  return out;
}

std::vector<std::string> NameTable::names() const {
  std::vector<std::string> out;
  for (const auto& [n, e] : entries_) out.push_back(n);
  return out;
}

// --------------------------------------------------------------------------------------------------- NameServer

struct NameServer::Lookup {
  NameTable::Waiter id = 0;
  std::weak_ptr<Channel> ch;
  wire::Message req;
  std::string name;
  std::chrono::milliseconds wait{0};
  bool waiting_locally = false;
  std::size_t peers_outstanding = 0;
  std::vector<std::string> peer_errors;
  bool done = false;
  std::unique_ptr<asio::steady_timer> timer;
};

struct NameServer::Peer {
  Address address;
  Channel::Ptr ch;
  bool connecting = false;
  std::vector<std::function<void(Channel::Ptr, const std::string&)>> waiting;
};

NameServer::NameServer(asio::io_context& io, std::string host, std::vector<Address> peers, ChannelOptions peer_options)
    : io_(io), host_(std::move(host)), peer_options_(std::move(peer_options)) {
  for (auto& a : peers) {
    auto p = std::make_unique<Peer>();
    p->address = std::move(a);
    peers_.push_back(std::move(p));
  }
}

NameServer::~NameServer() { stop(); }

namespace {
NameTable::Owner owner_of(const Channel* ch) { return static_cast<NameTable::Owner>(reinterpret_cast<std::uintptr_t>(ch)); }
}  // namespace

bool NameServer::handle(const Channel::Ptr& ch, const wire::Message& m) {
  if (m.type == "register") {
    std::string error;
    const std::string name = m.payload["name"].as_string();
    wire::Value endpoints = m.payload["endpoints"];
    if (endpoints.is_nil()) endpoints = wire::Value::map();
    if (!table_.add(name, endpoints, owner_of(ch.get()), &error)) {
      ch->reply_error(m, error + " on host " + host_);
      return true;
    }
    ch->reply(m, wire::Value::map().set("name", name).set("host", host_));
    // Wake the lookups waiting for it.
    for (auto w : table_.take_waiters(name)) {
      auto it = lookups_.find(w);
      if (it == lookups_.end()) continue;
      auto l = it->second;
      l->waiting_locally = false;
      const wire::Message found{
          "ok", 0, wire::Value::map().set("name", name).set("endpoints", endpoints).set("host", host_)};
      finish(l, &found, "");
    }
    return true;
  }
  if (m.type == "unregister") {
    std::string error;
    if (!table_.remove(m.payload["name"].as_string(), owner_of(ch.get()), &error)) {
      ch->reply_error(m, error + " on host " + host_);
    } else {
      ch->reply(m);
    }
    return true;
  }
  if (m.type == "lookup") {
    lookup(ch, m);
    return true;
  }
  return false;
}

void NameServer::channel_closed(const Channel* ch) { table_.remove_owner(owner_of(ch)); }

void NameServer::lookup(const Channel::Ptr& ch, const wire::Message& m) {
  const std::string name = m.payload["name"].as_string();
  if (name.empty()) {
    ch->reply_error(m, "lookup needs a name");
    return;
  }
  if (const auto* e = table_.find(name)) {
    ch->reply(m, wire::Value::map().set("name", name).set("endpoints", e->endpoints).set("host", host_));
    return;
  }
  const bool local_only = m.payload["local_only"].as_bool();
  const auto wait = std::chrono::milliseconds(std::clamp<std::int64_t>(m.payload["wait_ms"].as_int(0), 0, 3600000));
  if (stopped_ || (wait.count() == 0 && (local_only || peers_.empty()))) {
    ch->reply_error(m, "no process named '" + name + "' on host " + host_);
    return;
  }
  auto l = std::make_shared<Lookup>();
  l->id = next_waiter_++;
  l->ch = ch;
  l->req = m;
  l->name = name;
  l->wait = wait;
  lookups_[l->id] = l;
  if (wait.count() > 0) {
    l->waiting_locally = true;
    table_.wait(name, l->id);
    l->timer = std::make_unique<asio::steady_timer>(io_, wait);
    l->timer->async_wait([this, w = std::weak_ptr<Lookup>(l)](const boost::system::error_code& ec) {
      auto lk = w.lock();
      if (ec || !lk || lk->done) return;
      lk->waiting_locally = false;
      table_.cancel_wait(lk->id);
      if (lk->peers_outstanding == 0) finish(lk, nullptr, "");
    });
  }
  if (!local_only) {
    l->peers_outstanding = peers_.size();
    for (std::size_t i = 0; i < peers_.size(); ++i) ask_peer(i, l);
  }
  if (!l->done && !l->waiting_locally && l->peers_outstanding == 0) finish(l, nullptr, "");
}

void NameServer::ask_peer(std::size_t i, const std::shared_ptr<Lookup>& l) {
  with_peer(i, [this, i, l](Channel::Ptr peer, const std::string& error) {
    if (l->done) return;
    const auto peer_failed = [this, l, i](const std::string& why) {
      if (l->done) return;
      l->peer_errors.push_back(peers_[i]->address.str() + ": " + why);
      if (--l->peers_outstanding == 0 && !l->waiting_locally) finish(l, nullptr, "");
    };
    if (!peer) {
      peer_failed(error);
      return;
    }
    wire::Message ask{"lookup", 0,
                      wire::Value::map()
                          .set("name", l->name)
                          .set("wait_ms", static_cast<std::int64_t>(l->wait.count()))
                          .set("local_only", true)};
    peer->request(std::move(ask), l->wait + 2s, [this, l, peer_failed](Response r) {
      if (l->done) return;
      if (r.ok()) {
        --l->peers_outstanding;
        finish(l, &r.message, "");
      } else if (r.replied()) {
        // "not here": not an error worth reporting, just one fewer place to look.
        if (--l->peers_outstanding == 0 && !l->waiting_locally) finish(l, nullptr, "");
      } else {
        peer_failed(r.error);
      }
    });
  });
}

void NameServer::with_peer(std::size_t i, std::function<void(Channel::Ptr, const std::string&)> fn) {
  Peer& p = *peers_[i];
  if (p.ch && p.ch->is_open()) {
    fn(p.ch, "");
    return;
  }
  p.waiting.push_back(std::move(fn));
  if (p.connecting) return;
  p.connecting = true;
  Channel::connect(io_, p.address, peer_options_,
                   [this, i, alive = std::weak_ptr<int>(alive_)](Channel::Ptr ch, const std::string& error) {
                     if (!alive.lock()) {
                       if (ch) ch->close("the name server stopped");
                       return;
                     }
                     Peer& peer = *peers_[i];
                     peer.connecting = false;
                     peer.ch = ch;
                     if (ch && stopped_) ch->close("the name server stopped");
                     auto waiting = std::move(peer.waiting);
                     peer.waiting.clear();
                     for (auto& f : waiting) f(ch, ch ? "" : "unreachable: " + error);
                   });
}

void NameServer::finish(const std::shared_ptr<Lookup>& l, const wire::Message* found, const std::string& error) {
  if (l->done) return;
  l->done = true;
  if (l->timer) l->timer->cancel();
  table_.cancel_wait(l->id);
  lookups_.erase(l->id);
  auto ch = l->ch.lock();
  if (!ch) return;
  if (found != nullptr) {
    ch->reply(l->req, found->payload);
    return;
  }
  std::string why = error;
  if (why.empty()) {
    why = "no process named '" + l->name + "' on host " + host_;
    if (!l->req.payload["local_only"].as_bool() && !peers_.empty()) why += " or its " + std::to_string(peers_.size()) + " peers";
    if (l->wait.count() > 0) why += " within " + std::to_string(l->wait.count()) + " ms";
    if (!l->peer_errors.empty()) {
      why += " (";
      for (std::size_t k = 0; k < l->peer_errors.size(); ++k) why += (k ? "; " : "") + l->peer_errors[k];
      why += ")";
    }
  }
  ch->reply_error(l->req, why);
}

void NameServer::stop() {
  if (stopped_) return;
  stopped_ = true;
  auto lookups = lookups_;
  for (auto& [id, l] : lookups) finish(l, nullptr, "the name server on host " + host_ + " stopped");
  for (auto& p : peers_)
    if (p->ch) p->ch->close("the name server stopped");
}

}  // namespace dca
