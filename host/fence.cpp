#include "host/fence.h"

#include <signal.h>

#include <algorithm>
#include <cstdio>
#include <vector>

namespace dca {

namespace {
std::chrono::steady_clock::duration seconds(double s) {
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(s));
}
}  // namespace

Leases::Leases(boost::asio::io_context& io, Executer& exec, std::string host)
    : io_(io), exec_(exec), host_(std::move(host)) {}

void Leases::grant(const void* channel, const std::string& peer, Executer::ChildId id, const std::string& name,
                   double fence, double kill_after) {
  Lease& l = leases_[channel];
  if (!l.timer) {
    l.peer = peer;
    l.fence = fence;
    l.kill_after = kill_after;
    l.timer = std::make_unique<boost::asio::steady_timer>(io_);
  }
  l.fence = std::min(l.fence, fence);
  l.kill_after = std::min(l.kill_after, kill_after);
  l.children[id] = name;
  renew(channel);
}

void Leases::renew(const void* channel) {
  auto it = leases_.find(channel);
  if (it == leases_.end()) return;
  it->second.renewed = std::chrono::steady_clock::now();
  arm(channel, it->second);
}

void Leases::arm(const void* channel, Lease& l) {
  l.timer->expires_at(l.renewed + seconds(l.fence));
  l.timer->async_wait([this, channel](const boost::system::error_code& ec) {
    if (ec) return;  // renewed (the timer re-armed) or gone
    auto it = leases_.find(channel);
    if (it == leases_.end()) return;
    char why[160];
    std::snprintf(why, sizeof why, "its supervisor (%s) was silent for %.3f s (fence %g s)", it->second.peer.c_str(),
                  silent_for(channel), it->second.fence);
    fence(channel, why);
  });
}

void Leases::closed(const void* channel) {
  auto it = leases_.find(channel);
  if (it == leases_.end()) return;
  fence(channel, "its supervisor's channel (" + it->second.peer + ") closed");
}

// Ends the lease: SIGTERM to each of its children, SIGKILL kill_after later to one still there.
void Leases::fence(const void* channel, const std::string& why) {
  auto node = leases_.extract(channel);
  if (node.empty()) return;
  Lease& l = node.mapped();
  if (l.timer) l.timer->cancel();
  for (const auto& [id, name] : l.children) {
    // a shared node another lease still holds (another group's supervisor, heard from) lives on: its end comes
    // with the last lease that holds it
    const bool held = std::any_of(leases_.begin(), leases_.end(), [id = id](const auto& e) {
      return e.second.children.count(id) > 0;
    });
    if (held) continue;
    const std::string reason = "fenced on host " + host_ + ": " + why;
    std::fprintf(stderr, "dca daemon %s: %s: %s: SIGTERM, SIGKILL in %g s if it lives on\n", host_.c_str(),
                 name.c_str(), reason.c_str(), l.kill_after);
    if (on_fenced) on_fenced(id, reason);
    std::string error;
    if (!exec_.kill(id, SIGTERM, &error)) continue;  // ended meanwhile
    auto timer = std::make_unique<boost::asio::steady_timer>(io_, seconds(l.kill_after));
    timer->async_wait([this, id](const boost::system::error_code& ec) {
      if (ec) return;
      std::string e;
      exec_.kill(id, SIGKILL, &e);
    });
    kills_[id] = std::move(timer);
  }
}

void Leases::exited(Executer::ChildId id) {
  if (auto k = kills_.find(id); k != kills_.end()) {
    k->second->cancel();
    kills_.erase(k);
  }
  for (auto& [ch, l] : leases_) l.children.erase(id);
}

double Leases::silent_for(const void* channel) const {
  auto it = leases_.find(channel);
  if (it == leases_.end()) return -1;
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - it->second.renewed).count();
}

}  // namespace dca
