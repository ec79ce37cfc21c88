#pragma once
// Test and benchmark support: an in-process daemon and the door world hosted as the node `world` (the clock
// master, sim/device_node.h), on one Loop, with the control channels a test talks to them on.
#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "host/loop.h"  // before any other Asio header
#include "host/daemon.h"
#include "host/net/channel.h"
#include "host/node.h"
#include "sim/device_node.h"
#include "worlds/door/door_world.h"
#include "tests/support/channel_pair.h"

namespace dca::test {

/// The daemon and the world; `held` turns true when the world reaches its duration.
class SimWorld {
 public:
  SimWorld(Loop& on, DaemonOptions daemon_options, sim::DeviceNodeOptions world_options, std::string key_file,
           double command_timeout = 0.05)
      : loop(on),
        daemon(on.io(), daemon_options),
        device(sim::door_world(), command_timeout),
        world(device.world()),
        world_node(on, device, world_options),
        key_file_(std::move(key_file)),
        channel_options_{daemon_options.key} {
    world_node.on_duration = [this] { held = true; };
  }
  SimWorld(const SimWorld&) = delete;
  SimWorld& operator=(const SimWorld&) = delete;

  /// Starts the daemon, then the world's node (registered as `world`). False with *error if either failed.
  bool start(std::string* error) {
    if (!daemon.start(error)) return false;
    NodeOptions no;
    no.name = "world";
    no.daemon = daemon.address().str();
    no.key_file = key_file_;
    node = world_node.make_node(no);
    std::optional<std::string> started;
    node->start([&](const std::string& e) { started = e; });
    loop.run_until([&] { return started.has_value(); }, std::chrono::seconds(10));
    *error = started.value_or("the world's node did not start in 10 s");
    return error->empty();
  }

  /// The control address `name` registered at the daemon ("" if none).
  std::string control_of(const std::string& name) {
    const auto* e = daemon.names().table().find(name);
    return e ? e->endpoints["control"].as_string() : std::string();
  }

  /// A channel to `address`, or nullptr with *error.
  Channel::Ptr open(const std::string& address, std::string* error) {
    const auto to = Address::parse(address);
    if (!to) return *error = "bad address '" + address + "'", nullptr;
    return connect_channel(loop, *to, channel_options_, error);
  }

  /// Sends a request on `ch` and runs the loop until its response (at most `timeout` and 5 s more).
  Response call(const Channel::Ptr& ch, const std::string& type, wire::Value payload = wire::Value::map(),
                std::chrono::seconds timeout = std::chrono::seconds(10)) {
    std::optional<Response> r;
    ch->request({type, 0, std::move(payload)}, timeout, [&](Response x) { r = std::move(x); });
    loop.run_until([&] { return r.has_value(); }, timeout + std::chrono::seconds(5));
    return r.value_or(Response{{}, "no reply"});
  }

  /// Shuts the world's node down and stops the daemon.
  void stop(const std::string& why) {
    if (node) node->shutdown(why);
    daemon.stop();
  }

  Loop& loop;
  Daemon daemon;
  sim::DoorDeviceWorld device;
  sim::World& world;
  sim::DeviceNode world_node;
  std::unique_ptr<Node> node;
  bool held = false;

 private:
  std::string key_file_;
  ChannelOptions channel_options_;
};

}  // namespace dca::test
