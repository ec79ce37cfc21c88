#pragma once
// A GoogleTest fixture for controllers on simulated time: instances made from the registry, their DONE/ABORTED
// events collected, test sources fed into their inputs, their outputs read back. Time moves only when a test
// calls timers.advance_to().
#include <gtest/gtest.h>

#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <boost/asio/io_context.hpp>

#include <dca/registry.h>
#include "host/net/endpoint.h"
#include "host/port.h"
#include "host/timers.h"

namespace dca::testing {

class ControllerFixture : public ::testing::Test {
 public:
  static constexpr Nanos kMs = 1'000'000;
  static constexpr Nanos kTick = 10 * kMs;  ///< the controllers' default period

  /// start()'s error: "" when `c` started.
  static std::string started(Component& c) {
    std::string error;
    return c.start({}, &error) ? "" : error;
  }
  /// configure()'s error: "" when `c` is configured.
  static std::string configured(Component& c) {
    std::string error;
    return c.configure(&error) ? "" : error;
  }
  /// A packed msgpack string's text.
  static std::string unpack_string(const std::string& packed) {
    return msgpack::unpack(packed.data(), packed.size()).get().as<std::string>();
  }
  /// A packed msgpack number.
  static double unpack_double(const std::string& packed) {
    return msgpack::unpack(packed.data(), packed.size()).get().as<double>();
  }

 protected:
  /// A controller `type` named `name`, its ports on the endpoint, its events into `events`.
  Controller& make(const std::string& type, std::vector<std::string> params, const std::string& name) {
    cs.push_back(Registry::global().create(type, {name, "local", std::move(params), &timers, nullptr}));
    auto& c = *cs.back();
    c.on_event = [this, name](const ComponentEvent& e) { events.emplace_back(name, e); };
    ep.add_component(name, c.ports());
    return c;
  }
  /// What creating `type` throws (std::invalid_argument), or "no error".
  std::string make_error(const std::string& type, std::vector<std::string> params, const std::string& name) {
    try {
      Registry::global().create(type, {name, "local", std::move(params), &timers, nullptr});
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "no error";
  }
  /// A test source output `port` (a vector of `size` doubles, or `spec` as given) connected to `to`.`in`.
  Output& feed(const std::string& port, std::uint32_t size, const std::string& to, const std::string& in) {
    return feed(vector_port(port, size), to, in);
  }
  Output& feed(const PortSpec& spec, const std::string& to, const std::string& in) {
    if (!src_added) {
      ep.add_component("/src", src);
      src_added = true;
    }
    auto* o = src.find_output(spec.name);
    if (o == nullptr) o = &src.add_output(spec);
    connect("/src", spec.name, to, in);
    return *o;
  }
  /// A test source output feeding an input: feed(port, size, <the controller>, input).
  struct Feed {
    std::string port;
    std::uint32_t size;
    std::string input;
  };
  /// make(), feed() each of `feeds` into it, activate the connections and start it (a failure if it refuses).
  Controller& start(const std::string& type, std::vector<std::string> params, const std::string& name,
                    const std::vector<Feed>& feeds = {}) {
    auto& c = make(type, std::move(params), name);
    for (const auto& f : feeds) feed(f.port, f.size, name, f.input);
    ep.activate("s");
    EXPECT_EQ(started(c), "");
    return c;
  }
  /// The test source's output `port` (made by feed()).
  Output& source(const std::string& port) { return *src.find_output(port); }
  /// Connects from.out -> to.in in the connection set "s" (pushed, queue 16).
  void connect(const std::string& from, const std::string& out, const std::string& to, const std::string& in) {
    std::string err = "none";
    ep.connect({from, out, to, in, "s", Mode::Push, 16}, {}, [&](const std::string& e) { err = e; });
    ASSERT_EQ(err, "");
  }
  /// The latest sample written at `port` of `c` (zeros before the first; a scalar as one element).
  static Eigen::VectorXd latest(const Controller& c, const std::string& port) {
    const auto* out = const_cast<Controller&>(c).ports().find_output(port);
    EXPECT_NE(out, nullptr);
    if (!out->has_latest()) return Eigen::VectorXd::Zero(out->spec().size);  // not written yet
    msgpack::sbuffer sb;
    msgpack::packer<msgpack::sbuffer> pk(sb);
    out->pack_latest(pk);
    const auto oh = msgpack::unpack(sb.data(), sb.size());
    if (out->spec().type == PortType::Scalar) return Eigen::VectorXd::Constant(1, oh.get().as<double>());
    const auto v = oh.get().as<std::vector<double>>();
    return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
  }
  void TearDown() override {
    for (auto& c : cs) ep.remove_component(c->name());
    if (src_added) ep.remove_component("/src");
  }

  boost::asio::io_context io;
  TimerServer timers{io, ClockKind::Simulated};
  Endpoint ep{io, "local"};
  PortSet src;
  bool src_added = false;
  std::vector<std::unique_ptr<Controller>> cs;
  std::vector<std::pair<std::string, ComponentEvent>> events;
};

}  // namespace dca::testing
