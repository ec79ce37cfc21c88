// The Endpoint's public operations (host/net/endpoint.h) and the Impl's bookkeeping of trunks: finding or opening
// the connection to a peer, converging two of them, accepting. The connections and links themselves are in
// endpoint_trunk.cpp and endpoint_links.cpp (their declarations in endpoint_internal.h).
#include "host/net/endpoint_internal.h"

#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <stdexcept>

#include <boost/asio/ip/tcp.hpp>

namespace dca {

using endpoint_detail::LocalLink;
using endpoint_detail::StreamLink;
using endpoint_detail::Trunk;

// ------------------------------------------------------------------------------------------------ Endpoint ---

std::shared_ptr<Trunk> Endpoint::Impl::trunk_to(Transport t, const std::string& addr, std::string* error) {
  std::shared_ptr<Trunk> found;  // the oldest of the preferred kind, else the oldest
  const bool here = prefer_opened_here(t, addr);
  for (const auto& tr : trunks)
    if (tr->leads_to(t, addr) && (!found || (found->opener() != here && tr->opener() == here))) found = tr;
  if (found) return found;
  const auto to = t == Transport::Unix ? std::optional(Address::unix_socket(addr)) : Address::parse(addr, error);
  const auto where = to ? to_endpoint(*to, error) : std::nullopt;
  if (!where) return nullptr;
  auto tr = std::make_shared<Trunk>(*this, Socket(io), t, true);
  trunks.push_back(tr);
  tr->open(*where, addr);
  return tr;
}

void Endpoint::Impl::converge(Transport t, const std::string& addr) {
  std::shared_ptr<Trunk> preferred;  // the oldest ready one of the preferred kind
  for (const auto& tr : trunks)
    if (!preferred && tr->leads_to(t, addr) && tr->ready() && tr->opener() == prefer_opened_here(t, addr))
      preferred = tr;
  if (!preferred) return;
  for (const auto& tr : std::vector<std::shared_ptr<Trunk>>(trunks))
    if (tr != preferred && tr->leads_to(t, addr)) tr->move_links_to(preferred);
}

void Endpoint::Impl::accept(StreamAcceptor& acceptor, AcceptBackoff& backoff) {
  acceptor.async_accept([this, &acceptor, &backoff](const boost::system::error_code& ec, Socket s) {
    if (ec == asio::error::operation_aborted || closing) return;
    if (ec) {  // EMFILE and friends: back off instead of spinning, said on stderr at a bounded rate
      const auto say = [](const std::string& line) { std::fprintf(stderr, "dca: %s\n", line.c_str()); };
      return backoff.failed(ec, "a data port on host " + host, say, [this, &acceptor, &backoff] {
        if (!closing) accept(acceptor, backoff);
      });
    }
    backoff.succeeded();
    boost::system::error_code e2;
    const Transport t = s.local_endpoint(e2).protocol().family() == AF_UNIX ? Transport::Unix : Transport::Tcp;
    auto tr = std::make_shared<Trunk>(*this, std::move(s), t, false);
    trunks.push_back(tr);
    tr->begin();
    accept(acceptor, backoff);
  });
}

Endpoint::Endpoint(asio::io_context& io, std::string host, EndpointOptions options)
    : impl_(std::make_unique<Impl>(io, host, std::move(options))), host_(std::move(host)) {}

Endpoint::~Endpoint() {
  impl_->closing = true;
  boost::system::error_code ec;
  impl_->uds_backoff.cancel();
  impl_->tcp_backoff.cancel();
  if (impl_->uds_acceptor) impl_->uds_acceptor->close(ec);
  if (impl_->tcp_acceptor) impl_->tcp_acceptor->close(ec);
  if (!impl_->uds_path.empty()) ::unlink(impl_->uds_path.c_str());
  for (auto& l : impl_->links) l->close();
  for (auto& t : std::vector<std::shared_ptr<Trunk>>(impl_->trunks)) t->close_quietly();
}

void Endpoint::listen(const std::string& uds_path, const std::string& tcp_address) {
  std::string error;
  Address bound;
  if (!uds_path.empty()) {
    impl_->uds_acceptor = std::make_unique<StreamAcceptor>(impl_->io);
    if (!listen_at(*impl_->uds_acceptor, Address::unix_socket(uds_path), &bound, &error))
      throw std::runtime_error(error);
    impl_->uds_path = uds_path;
    impl_->accept(*impl_->uds_acceptor, impl_->uds_backoff);
  }
  if (!tcp_address.empty()) {
    const auto at = Address::parse(tcp_address, &error);
    impl_->tcp_acceptor = std::make_unique<StreamAcceptor>(impl_->io);
    if (!at || !listen_at(*impl_->tcp_acceptor, *at, &bound, &error)) throw std::runtime_error(error);
    impl_->tcp_address = bound.str();
    impl_->accept(*impl_->tcp_acceptor, impl_->tcp_backoff);
  }
}

Location Endpoint::location() const { return {host_, impl_->uds_path, impl_->tcp_address}; }

void Endpoint::add_component(const std::string& name, PortSet& ports) {
  if (impl_->components.count(name)) throw std::invalid_argument("component '" + name + "' is already registered");
  impl_->components.emplace(name, &ports);
  for (const auto& in : ports.inputs()) {
    Input* p = in.get();
    p->on_overflow = [this, name, p] {
      impl_->report({CommsEvent::Kind::Overflow, name, p->name(), "", "",
                     "queue of " + std::to_string(p->capacity()) + " full: dropping the oldest samples (counted)"});
    };
  }
}

void Endpoint::remove_component(const std::string& name) {
  auto it = impl_->components.find(name);
  if (it == impl_->components.end()) return;
  for (const auto& in : it->second->inputs()) in->on_overflow = nullptr;
  std::vector<std::shared_ptr<Connection>> keep;
  for (auto& l : impl_->links) {
    if (l->request().from == name || (l->info().transport == Transport::InProcess && l->request().to == name)) l->close();
    else keep.push_back(l);
  }
  impl_->links.swap(keep);
  for (auto& t : std::vector<std::shared_ptr<Trunk>>(impl_->trunks)) t->remove_component(name, host_);
  impl_->components.erase(it);
}

PortSet* Endpoint::component(std::string_view name) const {
  auto it = impl_->components.find(name);
  return it == impl_->components.end() ? nullptr : it->second;
}

void Endpoint::connect(const ConnectRequest& r, const Location& dest, ConnectDone done, int timeout_ms) {
  auto* from = component(r.from);
  if (!from) return done("no component '" + r.from + "' at " + host_);
  Output* out = from->find_output(r.out);
  if (!out) return done(from->no_such_output(r.from, r.out));
  const Transport t = choose_transport(host_, component(r.to) != nullptr, dest);
  const std::string addr = t == Transport::Unix ? dest.data_uds : t == Transport::Tcp ? dest.data_tcp : "";
  for (const auto& l : impl_->links) {
    const auto& q = l->request();
    if (q.from != r.from || q.out != r.out || q.to != r.to || q.in != r.in || q.set != r.set) continue;
    // The same connection is the one already made, unless it broke or its destination now lives elsewhere
    // (a restarted process) or is another instance at the same address (a leaf removed and added again in a
    // shared node, whose `Gone` for the old link may still be on its way): then it is replaced.
    if (!l->info().broken && l->address() == addr && l->dest_instance == dest.instance) return done("");
    impl_->remove_link(l.get());
    break;
  }
  auto flag = impl_->set_flag(r.from, r.set);
  if (auto pre = impl_->sets.find(Impl::flag_key("", r.set)); pre != impl_->sets.end() && *pre->second) *flag = true;
  if (t == Transport::InProcess) {
    Input* in = nullptr;
    const std::string error = impl_->check_destination(r, out->spec(), in);
    if (!error.empty()) return done(error);
    impl_->links.push_back(std::make_shared<LocalLink>(r, out, in, flag, impl_->gate(link_key(r), true)));
    impl_->links.back()->dest_instance = dest.instance;
    impl_->links.back()->clock = impl_->clock;
    return done("");
  }
  std::string error;
  auto trunk = impl_->trunk_to(t, addr, &error);
  if (!trunk) return done("cannot connect to " + r.to + "." + r.in + ": " + error);
  auto link = std::make_shared<StreamLink>(*impl_, r, t, out, flag);
  link->dest_instance = dest.instance;
  link->clock = impl_->clock;
  out->attach(link.get());
  impl_->links.push_back(link);
  link->start(std::move(trunk), addr, std::move(done), timeout_ms);
}

void Endpoint::disconnect_set(const std::string& set) {
  std::vector<std::shared_ptr<Connection>> keep;
  for (auto& l : impl_->links) {
    if (l->request().set == set) l->close();
    else keep.push_back(l);
  }
  impl_->links.swap(keep);
}

void Endpoint::activate(const std::string& set, const std::string& from) {
  impl_->switch_set(set, from, true);
  for (std::size_t i = 0; i < impl_->links.size(); ++i)
    if (impl_->links[i]->request().set == set && (from.empty() || impl_->links[i]->request().from == from))
      impl_->links[i]->on_activate();
}

void Endpoint::deactivate(const std::string& set, const std::string& from) { impl_->switch_set(set, from, false); }

void Endpoint::on_event(std::function<void(const CommsEvent&)> fn) { impl_->on_event = std::move(fn); }

void Endpoint::set_clock(std::function<std::int64_t()> now) { impl_->clock = std::move(now); }

bool Endpoint::active(const std::string& set) const {
  for (const auto& [key, flag] : impl_->sets)
    if (*flag && key.size() > set.size() && key.compare(key.size() - set.size(), set.size(), set) == 0 &&
        key[key.size() - set.size() - 1] == '\x1f')
      return true;
  return false;
}

void Endpoint::set_gated(bool on) {
  impl_->gated = on;
  for (auto& [key, g] : impl_->gates) g->gated = on;
}

void Endpoint::set_hold(std::function<bool(const std::string& to)> hold) { impl_->hold = std::move(hold); }

void Endpoint::release_held(const std::vector<std::string>& to) {
  if (impl_->holding.empty() || to.empty()) return;
  std::vector<StreamLink*> links;
  for (auto* l : impl_->holding)
    if (std::find(to.begin(), to.end(), l->request().to) != to.end()) links.push_back(l);
  std::vector<endpoint_detail::Trunk*> corked;
  for (auto* l : links)
    if (auto* t = l->trunk(); t && std::find(corked.begin(), corked.end(), t) == corked.end()) {
      t->cork();
      corked.push_back(t);
    }
  for (auto* l : links) l->release_held();
  for (auto* t : corked) t->uncork();
}

std::size_t Endpoint::held() const {
  std::size_t n = 0;
  for (const auto* l : impl_->holding) n += l->held();
  return n;
}

bool Endpoint::sending() const {
  for (const auto& t : impl_->trunks)
    if (!t->write_idle()) return true;
  return false;
}

std::vector<Endpoint::SentCount> Endpoint::sent_counts() const {
  std::vector<SentCount> v;
  for (const auto& l : impl_->links)
    if (l->request().mode == Mode::Push) v.push_back({l->request().to, link_key(l->request()), l->info().sent});
  return v;
}

// The input a gate feeds: the destination component's input named in the key ("from|out>to|in@set").
static Input* gate_input(const Endpoint::Impl& ep, const std::string& key) {
  const auto gt = key.find('>'), at = key.rfind('@');
  if (gt == std::string::npos || at == std::string::npos || at < gt) return nullptr;
  const std::string dest = key.substr(gt + 1, at - gt - 1);
  const auto bar = dest.find('|');
  if (bar == std::string::npos) return nullptr;
  auto it = ep.components.find(std::string_view(dest).substr(0, bar));
  return it == ep.components.end() ? nullptr : it->second->find_input(std::string_view(dest).substr(bar + 1));
}

bool Endpoint::release(const std::string& key, std::uint64_t n) {
  return impl_->gate(key, false).release(gate_input(*impl_, key), n);
}

std::uint64_t Endpoint::received(const std::string& key) const {
  auto it = impl_->gates.find(key);
  return it == impl_->gates.end() ? 0 : it->second->received();
}

std::vector<LinkInfo> Endpoint::links() const {
  std::vector<LinkInfo> v;
  for (const auto& l : impl_->links) v.push_back(l->info());
  return v;
}

std::size_t Endpoint::accepted() const {
  return static_cast<std::size_t>(
      std::count_if(impl_->trunks.begin(), impl_->trunks.end(), [](const auto& t) { return !t->opener(); }));
}
std::size_t Endpoint::connections() const { return impl_->trunks.size(); }
std::uint64_t Endpoint::bytes_received() const { return impl_->bytes_received; }
std::uint64_t Endpoint::refused() const { return impl_->refused; }

}  // namespace dca

