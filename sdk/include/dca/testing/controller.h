#pragma once
// dca::testing::ControllerUnderTest: one controller alone, for a package's unit tests (docs/packages.md,
// "Test one controller alone"). No sockets, no daemon, no supervisor: the controller is made from the registry
// as a node makes it, its inputs are fed by the test, its MainCalc runs on a simulated clock that moves only
// when the test steps it, and its outputs are read back.
//
//   #include <dca/testing/controller.h>
//   #include <gtest/gtest.h>
//   TEST(Pid, PushesTowardsTheSetpoint) {
//     dca::testing::ControllerUnderTest pid("Pid", {"1.0", "2.0"});  // setpoint 1, kp 2; period 0.01 default
//     pid.start();
//     pid.set("Measured", 0.25);
//     pid.step();                                  // one period: one MainCalc
//     EXPECT_DOUBLE_EQ(pid.get("Command"), 1.5);   // kp (setpoint - measured)
//     pid.halt();
//     EXPECT_EQ(pid.get("Command"), 0.0);          // an actuator is zero after halt()
//   }
//
// Built with dca_add_controller_test(NAME PACKAGE pkg SOURCES test.cpp LIBS GTest::gtest_main) (the CMake
// package `dca`), which links the package's own objects into the test: their types are in the registry when the
// first ControllerUnderTest is made. The library behind this header is dca::testing (libdca_testing.a).
//
// Everything runs on the calling thread; a ControllerUnderTest is not thread-safe.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <msgpack.hpp>

#include <dca/controller.h>

namespace dca::testing {

/// How a run ended by itself (Done or Abort).
struct Ended {
  bool done = false;    ///< DONE (true) or ABORTED (false)
  std::string reason;   ///< ABORTED: why
  std::string value;    ///< DONE: the value, msgpack bytes (a packed nil when there is none)
  /// DONE's value as a number. Throws std::runtime_error when it is not one.
  double number() const;
  /// DONE's value as text. Throws std::runtime_error when it is not text.
  std::string text() const;
};

/// One controller of a registered type, its inputs fed and its outputs read by the test, on simulated time.
class ControllerUnderTest {
 public:
  /// Makes a controller of `type` with `params`, the .dca arguments after the host, as text. Its path is `path`.
  /// Throws std::invalid_argument as a node's start fails: a bad parameter ("Pid /test: parameter 'kp' must be
  /// at least 0, got -1"), or an unknown type (listing the known ones).
  explicit ControllerUnderTest(std::string_view type, std::vector<std::string> params = {},
                               std::string path = "/test");
  ~ControllerUnderTest();
  ControllerUnderTest(const ControllerUnderTest&) = delete;
  ControllerUnderTest& operator=(const ControllerUnderTest&) = delete;

  // --- life cycle ---
  /// configure() then start() with no initial value (nil). Throws std::runtime_error with their reason.
  void start();
  /// The same with an initial value (any msgpack-packable value: what a value binding passes).
  template <class V>
  void start(const V& init) {
    msgpack::sbuffer sb;
    msgpack::pack(sb, init);
    start_bytes(sb.data(), sb.size());
  }
  /// configure() alone. Throws std::runtime_error with its reason.
  void configure();
  /// halt(): the timer and triggers stop, on_halt(), then every actuator output reads zero.
  void halt();
  /// Changes a live parameter as the node does between two ticks (Controller::set_parameter): "" when it took
  /// the value, else why not ("<Type> <path>: parameter 'kp' must be at least 0, got -1"; the old value kept).
  std::string set_parameter(std::string_view name, const std::string& text);
  /// The controller's state.
  Controller::State state() const;
  /// How the last run ended by itself (Done or Abort), or nothing (not ended, or started again since).
  const std::optional<Ended>& ended() const;

  // --- inputs: each call is one sample arriving, as from a push connection ---
  /// A sample at a scalar input. Throws std::invalid_argument for an unknown input or another type.
  void set(std::string_view input, double v);
  /// A sample at a vector or vectorx input. Throws std::invalid_argument for an unknown input, another type or,
  /// for vector[N], another size.
  void set(std::string_view input, const Eigen::VectorXd& v);
  /// A sample at a value input: any msgpack-packable value.
  template <class V>
  void set_value(std::string_view input, const V& v) {
    msgpack::sbuffer sb;
    msgpack::pack(sb, v);
    set_bytes(input, sb.data(), sb.size());
  }

  /// A message at a message input (its CDR). Throws std::invalid_argument for an unknown input or another type.
  template <msgs::Message M>
  void set_message(std::string_view input, const M& m) {
    std::vector<std::byte> b(msgs::cdr_max_size<M>);
    b.resize(msgs::cdr_encode(m, b));
    set_message_bytes(input, M::ros_name, b);
  }

  // --- outputs: the latest sample written ---
  /// A scalar output's latest sample (0 before the first). Throws std::invalid_argument for an unknown output
  /// or another type.
  double get(std::string_view output) const;
  /// A vector or vectorx output's latest sample (zeros of its size before the first; empty for vectorx).
  Eigen::VectorXd get_vector(std::string_view output) const;
  /// A value output's latest sample (nil before the first).
  msgpack::object_handle get_value(std::string_view output) const;
  /// A message output's latest message (M{} before the first). Throws std::invalid_argument for an unknown
  /// output or another type.
  template <msgs::Message M>
  M get_message(std::string_view output) const {
    M m{};
    (void)msgs::cdr_decode(message_bytes(output, M::ros_name), m);
    return m;
  }
  /// How many samples the output has written.
  std::uint64_t writes(std::string_view output) const;

  // --- time: simulated, it moves only here ---
  /// Moves the clock to the next timer deadline `n` times, running what is due at each (a PeriodicController:
  /// `n` MainCalc calls). With no timer pending it does nothing and returns false.
  bool step(int n = 1);
  /// Moves the clock `seconds` on, running every timer due on the way, in order.
  void advance(double seconds);
  /// The clock's time in seconds (0 when made).
  double now() const;
  /// MainCalc calls so far.
  std::uint64_t ticks() const;

  /// The controller itself (its state, name, type).
  Controller& controller();

 private:
  void start_bytes(const char* data, std::size_t n);
  void set_bytes(std::string_view input, const char* data, std::size_t n);
  void set_message_bytes(std::string_view input, std::string_view type, std::span<const std::byte> cdr);
  std::span<const std::byte> message_bytes(std::string_view output, std::string_view type) const;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dca::testing
