// The data plane's socket connections: DataSocket (frame I/O, the backlog, the deadlines) and Trunk (the one
// socket connection between two endpoints: handshake, introduction, then every link between them, both ways).
#include "host/net/endpoint_internal.h"

#include <netinet/in.h>
#include <netinet/tcp.h>

#include <algorithm>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>

namespace dca::endpoint_detail {

namespace {
std::string ms_text(std::chrono::milliseconds d) { return std::to_string(d.count()) + " ms"; }
}  // namespace

// ---------------------------------------------------------------------------------------------- DataSocket ---

bool DataSocket::send(Kind kind, std::uint32_t link, Bytes body) {
  if (!sending()) return false;
  if (body.size() > data_frame::kMaxBody) return false;  // the peer would fail the connection (every link on it)
  if (!framed_.idle() && framed_.queued() > kMaxBacklog) return false;
  std::array<std::byte, data_frame::kHeader> h;
  data_frame::put_header(h.data(), kind, link, body.size());
  const std::array<std::string_view, 2> parts{
      std::string_view(reinterpret_cast<const char*>(h.data()), h.size()),
      std::string_view(reinterpret_cast<const char*>(body.data()), body.size())};
  if (batch_) {
    for (const auto& p : parts) batch_->append(p);
    return true;
  }
  return write(parts);
}

void DataSocket::uncork() {
  const auto batch = std::exchange(batch_, std::nullopt);
  if (batch && !batch->empty() && sending()) {
    const std::array<std::string_view, 1> parts{*batch};
    write(parts);
  }
}

void DataSocket::send_auth(const auth::Handshake::Step& step) {
  for (const auto& m : step.out) send(Kind::Auth, 0, as_bytes(data_frame::encode_auth(m)));
}

bool DataSocket::write(std::span<const std::string_view> parts) {
  boost::system::error_code ec;
  if (framed_.write_now(parts, shared_from_this(), ec)) return true;
  // A write error breaks the connection from the loop, never inside the sender's call (which may be holding
  // one of the links that the break ends).
  phase_ = Phase::Failing;
  asio::post(framed_.socket().get_executor(), [self = shared_from_this(), why = ec.message()] { self->fail(why); });
  return false;
}

void DataSocket::start_read() {
  if (phase_ != Phase::Closed) framed_.read(shared_from_this());
}

void DataSocket::shut() {
  if (phase_ == Phase::Closed) return;
  phase_ = Phase::Closed;
  wake_.cancel();
  framed_.close();
}

void DataSocket::close_after_flush() {
  if (framed_.idle()) shut();
  else if (phase_ == Phase::Open) phase_ = Phase::Flushing;
}

void DataSocket::fail(const std::string& reason) {
  if (phase_ == Phase::Closed) return;
  shut();
  on_broken(reason);
}

void DataSocket::set_handshake_deadline(std::chrono::milliseconds d) {
  handshake_timeout_ = d;
  handshake_at_ = Clock::now() + d;
  wake_at(handshake_at_);
}

void DataSocket::on_written(const boost::system::error_code& ec, std::size_t) {
  if (phase_ == Phase::Closed) return;
  if (ec) return fail(ec.message());
  if (framed_.queued() == 0 && phase_ == Phase::Flushing) shut();
}

void DataSocket::on_read(const boost::system::error_code& ec, std::size_t n) {
  if (phase_ == Phase::Closed) return;
  if (ec) return fail(ec == asio::error::eof ? "closed by peer" : ec.message());
  on_bytes(n);
  bool consumed = false;
  for (;;) {
    const auto unread = framed_.unread();
    data_frame::Frame f;
    std::size_t used = 0;
    std::string error;
    const auto r = data_frame::parse_frame({reinterpret_cast<const std::byte*>(unread.data()), unread.size()}, f,
                                           used, &error, frame_limit());
    if (r == data_frame::Parse::Error) return on_malformed(error);
    if (r == data_frame::Parse::NeedMore) break;
    on_frame(f.kind, f.link, f.body);
    if (phase_ == Phase::Closed || phase_ == Phase::Flushing) return;  // closed, or refused and closing
    framed_.consume(used);
    consumed = true;
  }
  watch_partial(consumed);
  start_read();
}

void DataSocket::watch_partial(bool consumed) {
  if (framed_.unread().empty()) {
    partial_at_ = Clock::time_point::max();
    return;
  }
  if (partial_at_ != Clock::time_point::max() && !consumed) return;
  partial_at_ = Clock::now() + partial_timeout_;
  wake_at(partial_at_);
}

void DataSocket::wake_at(Clock::time_point at) {
  if (phase_ == Phase::Closed || wake_time_ <= at) return;
  wake_time_ = at;
  wake_.expires_at(at);
  const auto gen = ++wake_gen_;
  std::weak_ptr<DataSocket> w = weak_from_this();
  wake_.async_wait([w, gen](const boost::system::error_code&) {
    if (auto s = w.lock(); s && gen == s->wake_gen_) s->on_wake();
  });
}

void DataSocket::on_wake() {
  wake_time_ = Clock::time_point::max();
  if (phase_ == Phase::Closed) return;
  const auto now = Clock::now();
  if (now >= handshake_at_) return fail("no authenticated introduction within " + ms_text(handshake_timeout_));
  if (now >= partial_at_) return fail("a partial data frame was held for more than " + ms_text(partial_timeout_));
  const auto next = std::min(handshake_at_, partial_at_);
  if (next != Clock::time_point::max()) wake_at(next);
}

// --------------------------------------------------------------------------------------------------- Trunk ---

void Trunk::open(const StreamEndpoint& where, std::string addr) {
  addr_ = std::move(addr);
  set_handshake_deadline(ep_->opts.handshake_timeout);
  auto self = std::static_pointer_cast<Trunk>(shared_from_this());
  sock().async_connect(where, [self](const boost::system::error_code& ec) {
    if (self->closed()) return;
    if (ec) return self->down(Down::Connect, ec.message());
    self->set_up_socket();
    const auto step = self->handshake_.start();
    if (step.state == auth::Handshake::State::kFailed) return self->down(Down::NoKey, "");
    self->send_auth(step);
    self->start_read();
  });
}

void Trunk::begin() {
  set_up_socket();
  set_handshake_deadline(ep_->opts.handshake_timeout);
  const auto step = handshake_.start();
  send_auth(step);
  if (step.state == auth::Handshake::State::kFailed) return refuse("this endpoint has no cluster key", false);
  start_read();
}

std::uint32_t Trunk::add_out(StreamLink* l) {
  const std::uint32_t id = next_id_++;
  out_.emplace(id, l);
  if (phase_ == Phase::Ready) send(Kind::Hello, id, as_bytes(l->hello()));
  return id;
}

void Trunk::remove_out(std::uint32_t id) {
  if (out_.erase(id) != 0 && phase_ == Phase::Ready) send(Kind::Close, id, {});
}

void Trunk::input_gone(std::uint32_t id, const std::string& why) {
  auto it = in_.find(id);
  if (it == in_.end()) return;
  auto gone = std::move(it->second);
  in_.erase(it);
  send(Kind::Gone, id, as_bytes(why));
}

void Trunk::remove_component(const std::string& name, const std::string& host) {
  std::vector<std::uint32_t> ids;
  for (const auto& [id, l] : in_)
    if (l->request_of().to == name) ids.push_back(id);
  for (auto id : ids) input_gone(id, name + " was removed from host " + host);
}

void Trunk::close_quietly() {
  ep_ = nullptr;
  for (auto& [id, l] : in_) l->detach();
  in_.clear();
  out_.clear();
  shut();
}

bool Trunk::leads_to(Transport t, const std::string& addr) const {
  return transport_ == t && !closed() && ep_ != nullptr && !addr.empty() && addr_ == addr;
}

void Trunk::on_bytes(std::size_t n) {
  if (ep_) ep_->bytes_received += n;
}

void Trunk::on_frame(Kind kind, std::uint32_t link, Bytes body) {
  if (!ep_) return;
  switch (phase_) {
    case Phase::Ready:
      return on_link_frame(kind, link, body);
    case Phase::Authenticating:
      return on_auth(kind, body);
    case Phase::Introducing:
      if (!opener_) return on_peer(kind, body);
      break;
  }
  fail("unexpected data frame kind " + std::to_string(static_cast<int>(kind)) + " before the handshake ended");
}

std::uint32_t Trunk::frame_limit() const {
  return phase_ != Phase::Authenticating ? data_frame::kMaxFrame : data_frame::kMaxAuthFrame;
}

void Trunk::on_malformed(const std::string& why) {
  if (phase_ != Phase::Authenticating || opener_) return fail("malformed data frame: " + why);
  refuse("authentication required: " + why, true);
}

void Trunk::set_up_socket() {
  boost::system::error_code ignored;
  if (transport_ == Transport::Tcp) sock().set_option(asio::ip::tcp::no_delay(true), ignored);
  sock().non_blocking(true, ignored);
}

void Trunk::on_auth(Kind kind, Bytes body) {
  if (opener_ && kind == Kind::HelloError)
    return down(Down::Refused, std::string(reinterpret_cast<const char*>(body.data()), body.size()));
  if (kind != Kind::Auth) {
    if (opener_) return down(Down::Auth, "the peer sent a data frame before the handshake ended");
    return refuse("authentication required: the cluster-key handshake comes first", true);
  }
  wire::Message m;
  std::string error;
  if (!data_frame::decode_auth(body, m, &error)) {
    if (opener_) return down(Down::Auth, error);
    return refuse(error, true);
  }
  const auto step = handshake_.on_message(m);
  send_auth(step);
  if (step.state == auth::Handshake::State::kFailed) {
    if (opener_) return down(Down::Auth, handshake_.reason());
    return refuse(handshake_.reason(), false);
  }
  if (step.state != auth::Handshake::State::kDone) return;
  phase_ = Phase::Introducing;
  if (opener_) introduce();
}

void Trunk::introduce() {
  cork();  // the introduction and the hellos waiting for it go in one write
  send(Kind::Peer, 0, as_bytes(data_frame::encode_peer({ep_->host, ep_->uds_path, ep_->tcp_address})));
  phase_ = Phase::Ready;
  clear_handshake_deadline();
  ep_->converge(transport_, addr_);  // may move this connection's links to the peer's (then this one closes)
  for (const auto& [id, l] : std::map<std::uint32_t, StreamLink*>(out_)) send(Kind::Hello, id, as_bytes(l->hello()));
  uncork();
  close_if_idle();
}

void Trunk::on_peer(Kind kind, Bytes body) {
  Location peer;
  std::string error;
  if (kind != Kind::Peer) error = "the first data frame after the handshake must introduce the peer";
  else data_frame::decode_peer(body, peer, &error);
  if (!error.empty()) return refuse(error, true);
  addr_ = transport_ == Transport::Unix ? peer.data_uds : peer.data_tcp;
  phase_ = Phase::Ready;
  clear_handshake_deadline();
  ep_->converge(transport_, addr_);
}

void Trunk::on_link_frame(Kind kind, std::uint32_t id, Bytes body) {
  switch (kind) {
    case Kind::Sample:
    case Kind::Pulled:
      if (auto it = in_.find(id); it != in_.end()) it->second->deliver(kind, body);
      return;  // a link closed meanwhile: its last samples are dropped
    case Kind::Hello:
      return on_hello(id, body);
    case Kind::Close:
      return close_in(id, std::string_view(reinterpret_cast<const char*>(body.data()), body.size()) == kMoved);
    case Kind::HelloOk:
    case Kind::HelloError:
    case Kind::PullRequest:
    case Kind::Gone:
      return on_answer(kind, id, body);
    default:
      break;
  }
  fail("unexpected data frame kind " + std::to_string(static_cast<int>(kind)));
}

void Trunk::on_answer(Kind kind, std::uint32_t id, Bytes body) {
  if (kind == Kind::HelloError && id == 0)
    return down(Down::Refused, std::string(reinterpret_cast<const char*>(body.data()), body.size()));
  auto it = out_.find(id);
  if (it == out_.end()) return;
  StreamLink* l = it->second;
  const std::string text(reinterpret_cast<const char*>(body.data()), body.size());
  if (kind == Kind::HelloOk) return l->accepted();
  if (kind == Kind::PullRequest) return l->pull_requested();
  out_.erase(it);
  if (kind == Kind::HelloError) l->refused(text);
  else l->trunk_down(Down::Closed, text);
}

void Trunk::on_hello(std::uint32_t id, Bytes body) {
  if (in_.count(id) != 0) return fail("a second hello for link " + std::to_string(id));
  data_frame::Hello h;
  std::string error;
  Input* in = nullptr;
  if (in_.size() >= kMaxLinks) error = "too many links on one connection";
  else if (data_frame::decode_hello(body, h, &error)) error = ep_->check_destination(h.request, h.out, in);
  if (!error.empty()) {
    ++ep_->refused;
    send(Kind::HelloError, id, as_bytes(error));
    return;
  }
  // a moved link's earlier hello, read after its later one on the other socket, neither resets nor takes the gate
  auto& gate = ep_->gate(link_key(h.request), false);
  if (gate.later(h.sender, h.serial) && gate.received() > 0) gate.reset();
  in_.emplace(id, std::make_unique<InLink>(*this, id, h, in, gate));
  send(Kind::HelloOk, id, {});
}

void Trunk::close_in(std::uint32_t id, bool moved) {
  auto it = in_.find(id);
  if (it == in_.end()) return;
  auto l = std::move(it->second);
  in_.erase(it);
  if (!moved) report_in(*ep_, *l, "closed by peer");
}

bool Trunk::close_if_idle() {
  if (!opener_ || phase_ != Phase::Ready || !out_.empty() || !in_.empty() || !ep_) return false;
  auto keep = shared_from_this();
  std::exchange(ep_, nullptr)->drop_trunk(this);
  uncork();  // the introduction goes first: the peer then sees an introduced connection close
  shut();
  return true;
}

void Trunk::report_in(Endpoint::Impl& ep, const InLink& l, const std::string& reason) {
  const auto& r = l.request_of();
  ep.report({CommsEvent::Kind::Broken, r.to, r.in, r.from + "." + r.out, r.set, reason});
}

void Trunk::down(Down how, const std::string& reason) {
  auto* ep = std::exchange(ep_, nullptr);
  shut();
  if (!ep) return;
  if (!opener_ && phase_ != Phase::Ready) ++ep->refused;  // accepted, never introduced
  auto keep = shared_from_this();
  ep->drop_trunk(this);
  for (auto& [id, l] : std::exchange(in_, {})) {
    l->detach();
    report_in(*ep, *l, reason);
  }
  for (const auto& [id, l] : std::exchange(out_, {})) l->trunk_down(how, reason);
}

void Trunk::refuse(const std::string& why, bool tell) {
  auto* ep = std::exchange(ep_, nullptr);
  if (!ep) return;
  ++ep->refused;
  if (tell) send(Kind::HelloError, 0, as_bytes(why));
  close_after_flush();
  ep->drop_trunk(this);
}

void Trunk::move_links_to(const std::shared_ptr<Trunk>& to) {
  for (const auto& [id, l] : std::map<std::uint32_t, StreamLink*>(out_)) {
    if (!l->movable()) continue;
    out_.erase(id);
    if (phase_ == Phase::Ready) send(Kind::Close, id, as_bytes(kMoved));
    l->move_to(to);
  }
  close_if_idle();
}

}  // namespace dca::endpoint_detail
