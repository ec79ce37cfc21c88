#include "host/loop.h"

#include <boost/asio/steady_timer.hpp>

#include <sched.h>

#include <algorithm>

namespace dca {

Loop::Loop() = default;

// The signal sets go before the io_context whose service they are registered with.
Loop::~Loop() {
  boost::system::error_code ec;
  for (auto& [signal, extra] : extra_)
    if (extra.first) extra.first->cancel(ec);
  extra_.clear();
  if (signals_) {
    signals_->cancel(ec);
    signals_.reset();
  }
}

std::size_t Loop::run() {
  io_.restart();
  if (!may_spin_) return io_.run();
  std::size_t total = 0;
  for (;;) {
    if (spin_until_ != std::chrono::steady_clock::time_point{}) {  // in a spin window: poll, yield, poll
      const std::size_t n = io_.poll();
      total += n;
      ++spun_;
      if (io_.stopped()) break;
      if (n == 0) {
        if (std::chrono::steady_clock::now() >= spin_until_) spin_until_ = {};
        else sched_yield();  // polite: any other runnable process on this CPU goes first
      }
      continue;
    }
    const std::size_t n = io_.run_one();
    total += n;
    if (n == 0) break;  // stopped, or out of work
  }
  return total;
}

void Loop::spin_for(std::chrono::microseconds window) {
  if (!may_spin_ || window.count() <= 0) return;
  spin_until_ = std::max(spin_until_, std::chrono::steady_clock::now() + window);
}

std::size_t Loop::settle(int max_rounds) {
  std::size_t total = 0;
  for (int i = 0; i < max_rounds && !io_.stopped(); ++i) {
    const std::size_t n = io_.poll();
    if (n == 0) break;
    total += n;
  }
  return total;
}

bool Loop::run_until(const std::function<bool()>& done, std::chrono::nanoseconds timeout) {
  if (done()) return true;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  io_.restart();
  for (;;) {
    const auto now = std::chrono::steady_clock::now();
    if (now >= deadline) return done();
    // run_one_until returns 0 at the deadline, or when the context is stopped or out of work.
    const std::size_t n = io_.run_one_until(deadline);
    if (done()) return true;
    if (n == 0) {
      if (io_.stopped()) {
        // Out of work (or stopped): nothing can make done() true before the deadline except another thread.
        return done();
      }
    }
  }
}

void Loop::run_for(std::chrono::nanoseconds duration) {
  io_.restart();
  io_.run_for(duration);
}

void Loop::stop() { io_.stop(); }

void Loop::on_signals(std::initializer_list<int> signals, std::function<void(int)> fn) {
  if (signals_) {
    boost::system::error_code ec;
    signals_->cancel(ec);
  }
  signals_ = std::make_unique<boost::asio::signal_set>(io_);
  for (int s : signals) signals_->add(s);
  on_signal_ = std::move(fn);
  wait_signal();
}

void Loop::on_signal(int signal, std::function<void()> fn) {
  auto& e = extra_[signal];
  if (e.first) {
    boost::system::error_code ec;
    e.first->cancel(ec);
  }
  e.first = std::make_unique<boost::asio::signal_set>(io_, signal);
  e.second = std::move(fn);
  wait_extra(e.first.get(), signal);
}

void Loop::wait_extra(boost::asio::signal_set* set, int signal) {
  set->async_wait([this, set, signal](const boost::system::error_code& ec, int) {
    auto it = extra_.find(signal);
    if (ec || it == extra_.end() || it->second.first.get() != set) return;  // cancelled or replaced
    if (it->second.second) it->second.second();
    it = extra_.find(signal);
    if (it != extra_.end() && it->second.first.get() == set) wait_extra(set, signal);
  });
}

void Loop::wait_signal() {
  signals_->async_wait([this, set = signals_.get()](const boost::system::error_code& ec, int sig) {
    if (ec || set != signals_.get()) return;  // cancelled or replaced
    if (on_signal_) on_signal_(sig);
    if (signals_ && set == signals_.get()) wait_signal();
  });
}

}  // namespace dca
