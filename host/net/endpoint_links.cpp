// The data plane's links: LocalLink (in-process: the sample copied straight into the input), StreamLink (the
// source of a link over a socket: its hello, then its samples, on the Trunk to the destination) and InLink (the
// destination of one: feeds a local input with what the Trunk receives for it).
#include "host/net/endpoint_internal.h"

namespace dca::endpoint_detail {

// ----------------------------------------------------------------------------------------------- LocalLink ---

void LocalLink::on_write(Bytes b) {
  if (info_.request.mode == Mode::Pull) {
    if (pending_ && *active_) answer();
    return;
  }
  if (!*active_ || !in_) {
    ++info_.skipped;
    return;
  }
  ++info_.sent;
  gate_->deliver(*in_, body(b), this);
}

void LocalLink::request() {
  pending_ = true;
  if (*active_) answer();
}

void LocalLink::on_activate() {
  if (pending_) answer();
}

void LocalLink::close() {
  if (in_) {
    in_->remove_feeder(this);
    in_->remove_pull_source(this);
  }
  in_ = nullptr;
  Connection::close();
}

void LocalLink::answer() {
  if (!out_ || !in_ || !out_->has_latest()) return;
  pending_ = false;
  ++info_.sent;
  in_->deliver_pulled(out_->latest_bytes());
}

// ------------------------------------------------------------------------------------ InLink and StreamLink ---

void InLink::request() { trunk_->send(Kind::PullRequest, id_, {}); }

void InLink::input_gone() {
  in_ = nullptr;
  trunk_->input_gone(id_, "input " + r_.to + "." + r_.in + " is gone");  // destroys this
}

void StreamLink::start(std::shared_ptr<Trunk> trunk, const std::string& addr, Endpoint::ConnectDone done,
                       int timeout_ms) {
  done_ = std::move(done);
  peer_ = info_.request.to + "." + info_.request.in;
  peer_addr_ = addr;
  trunk_ = std::move(trunk);
  std::weak_ptr<Connection> w = weak_from_this();
  timer_.expires_after(std::chrono::milliseconds(timeout_ms));
  timer_.async_wait([w, timeout_ms](const boost::system::error_code& ec) {
    auto self = std::static_pointer_cast<StreamLink>(w.lock());
    if (ec || !self || self->connected_ || !self->done_) return;
    self->finish("no answer from " + self->peer_ + " at " + self->peer_addr_ + " within " +
                 std::to_string(timeout_ms) + " ms");
  });
  id_ = trunk_->add_out(this);
}

void StreamLink::move_to(std::shared_ptr<Trunk> to) {
  trunk_ = std::move(to);
  id_ = trunk_->add_out(this);
}

void StreamLink::on_write(Bytes b) {
  if (!connected_ || info_.broken) return;
  if (info_.request.mode == Mode::Pull) {
    if (pending_ && *active_) answer();
    return;
  }
  if (!*active_) {
    ++info_.skipped;
    return;
  }
  const Bytes sample = body(b);
  if (oversized(sample)) return;
  if (ep_ && ep_->hold && ep_->hold(info_.request.to)) {  // kept back until its reader's node is advanced
    if (held_sizes_.empty()) ep_->holding.push_back(this);
    held_.insert(held_.end(), sample.begin(), sample.end());
    held_sizes_.push_back(static_cast<std::uint32_t>(sample.size()));
    ++info_.sent;
    info_.bytes += data_frame::kHeader + sample.size();
    return;
  }
  if (!held_sizes_.empty()) release_held();  // those kept back go first
  if (trunk_->send(Kind::Sample, id_, sample)) {
    ++info_.sent;
    info_.bytes += data_frame::kHeader + sample.size();
  } else {
    ++info_.tx_dropped;
  }
}

void StreamLink::release_held() {
  std::size_t at = 0;
  for (const auto n : held_sizes_) {
    if (!trunk_ || !trunk_->send(Kind::Sample, id_, Bytes(held_.data() + at, n))) ++info_.tx_dropped;
    at += n;
  }
  drop_held();
}

void StreamLink::drop_held() {
  if (held_sizes_.empty()) return;
  held_.clear();
  held_sizes_.clear();
  if (ep_) std::erase(ep_->holding, this);
}

void StreamLink::close() {
  drop_held();
  Connection::close();
  ep_ = nullptr;
  timer_.cancel();
  if (auto t = std::exchange(trunk_, nullptr)) t->remove_out(id_);
}

void StreamLink::accepted() {
  if (connected_) return;
  connected_ = true;
  timer_.cancel();
  if (done_) std::exchange(done_, nullptr)("");
  if (pending_ && *active_) answer();
}

void StreamLink::trunk_down(Down how, const std::string& reason) {
  trunk_ = nullptr;
  if (done_) {
    switch (how) {
      case Down::Connect:
        return finish("cannot connect to " + peer_ + " at " + peer_addr_ + ": " + reason);
      case Down::NoKey:
        return finish("cannot connect to " + peer_ + ": this endpoint has no cluster key");
      case Down::Auth:
        return finish("data connection to " + peer_ + " at " + peer_addr_ + " not authenticated: " + reason);
      case Down::Refused:
        return finish(reason);
      case Down::Closed:
        return finish("connection to " + peer_ + " closed before it was accepted: " + reason);
    }
  }
  connected_ = false;
  info_.broken = true;
  if (ep_)
    ep_->report({CommsEvent::Kind::Broken, info_.request.from, info_.request.out, peer_, info_.request.set, reason});
}

void StreamLink::answer() {
  if (!out_ || !out_->has_latest() || !trunk_) return;
  pending_ = false;
  const Bytes b = out_->latest_bytes();
  if (oversized(b)) return;
  if (trunk_->send(Kind::Pulled, id_, b)) {
    ++info_.sent;
    info_.bytes += data_frame::kHeader + b.size();
  }
}

// A sample too big for one data frame is dropped here, counted in tx_dropped and reported once per link, as an
// overflow: sent, it would make the peer fail the whole connection, every link between the two processes.
bool StreamLink::oversized(Bytes b) {
  if (b.size() <= data_frame::kMaxBody) return false;
  ++info_.tx_dropped;
  if (!std::exchange(oversize_reported_, true) && ep_)
    ep_->report({CommsEvent::Kind::Overflow, info_.request.from, info_.request.out, peer_, info_.request.set,
                 "sample of " + std::to_string(b.size()) + " bytes exceeds the data frame limit of " +
                     std::to_string(data_frame::kMaxBody) + " bytes: dropped (counted in tx_dropped)"});
  return true;
}

// Opening failed: report once, then remove this link.
void StreamLink::finish(const std::string& error) {
  auto done = std::exchange(done_, nullptr);
  auto* ep = ep_;
  timer_.cancel();
  if (auto t = std::exchange(trunk_, nullptr)) t->remove_out(id_);
  if (ep) ep->remove_link(this);
  if (done) done(error);
}

}  // namespace dca::endpoint_detail
