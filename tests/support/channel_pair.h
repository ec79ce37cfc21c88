#pragma once
// Test and benchmark support for the control plane: the names every channel test uses, the shared test key,
// and a blocking connect (the loop runs until the channel is open or refused).
#include "host/loop.h"  // first: Asio with GCC 12's false positives silenced

#include <chrono>
#include <string>

#include "host/net/channel.h"

namespace dca::test {

using dca::Address;
using dca::Channel;
using dca::ChannelOptions;
using dca::Listener;
using dca::Response;
using dca::wire::Message;
using dca::wire::Value;

/// The cluster key of the tests (32 bytes).
inline const std::string kKey = "0123456789abcdef0123456789abcdef";

/// Connects to `to` with `options`, running `loop` until the connect finishes (at most `wait`): the open
/// channel, or nullptr with *error. Returns nullptr with "connect never finished" when `wait` passes.
inline Channel::Ptr connect_channel(Loop& loop, const Address& to, ChannelOptions options, std::string* error = nullptr,
                                    std::chrono::milliseconds wait = std::chrono::seconds(10)) {
  Channel::Ptr out;
  bool done = false;
  std::string err = "connect never finished";
  Channel::connect(loop.io(), to, std::move(options), [&](Channel::Ptr ch, const std::string& e) {
    out = std::move(ch);
    err = e;
    done = true;
  });
  loop.run_until([&] { return done; }, wait);
  if (error != nullptr) *error = err;
  return out;
}

}  // namespace dca::test
