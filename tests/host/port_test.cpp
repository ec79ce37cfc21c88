// Ports (pure): names of types and modes, compatibility, the PortSet's errors, choosing a transport, sizes.
#include "host/port.h"

#include <gtest/gtest.h>

#include <array>
#include <cstring>
#include <map>
#include <stdexcept>

#include <dca/msgs_cdr.h>

#include "host/codec/wire.h"

namespace {

TEST(PortTest, NamesTypesAndModes) {
  EXPECT_EQ(dca::to_string(dca::PortType::VectorX), "vectorx");
  EXPECT_EQ(dca::port_type_from("vector"), dca::PortType::Vector);
  EXPECT_FALSE(dca::port_type_from("matrix"));
  EXPECT_EQ(dca::mode_from("pull"), dca::Mode::Pull);
  EXPECT_FALSE(dca::mode_from("poll"));
}

TEST(PortTest, CompatibilityChecksTypeAndSize) {
  EXPECT_EQ(dca::compatibility_error(dca::vector_port("A", 3), dca::vector_port("B", 3)), "");
  EXPECT_EQ(dca::compatibility_error(dca::vector_port("A", 3), dca::vector_port("B", 4)),
            "output 'A' is vector[3] but input 'B' is vector[4]");
  // a vectorx end takes the other's size; a scalar is one double, so it meets a vector[1]
  EXPECT_EQ(dca::compatibility_error(dca::scalar_port("A"), dca::vectorx_port("B")), "");
  EXPECT_EQ(dca::compatibility_error(dca::vectorx_port("A"), dca::scalar_port("B")), "");
  EXPECT_EQ(dca::compatibility_error(dca::vectorx_port("A"), dca::vector_port("B", 6)), "");
  EXPECT_EQ(dca::compatibility_error(dca::vector_port("A", 1), dca::scalar_port("B")), "");
  EXPECT_EQ(dca::compatibility_error(dca::vector_port("A", 3), dca::scalar_port("B")),
            "output 'A' is vector[3] but input 'B' is scalar");
  // values go to values only
  EXPECT_EQ(dca::compatibility_error(dca::value_port("A"), dca::vectorx_port("B")),
            "output 'A' is value but input 'B' is vectorx");
  EXPECT_EQ(dca::compatibility_error(dca::scalar_port("A"), dca::value_port("B")),
            "output 'A' is scalar but input 'B' is value");
  EXPECT_EQ(dca::compatibility_error(dca::value_port("A"), dca::value_port("B")), "");
}

// A port's latest as msgpack (`read`, a trace's digests, the monitor) reads back as the same doubles, 1e19 too
// (msgpack-c would write it as an unsigned integer above INT64_MAX, which dca's decoder refused).
TEST(PortTest, ALatestSampleBeyondInt64PacksAsADoubleThatReadsBack) {
  dca::Input scalar(dca::scalar_port("In"), 2), vec(dca::vectorx_port("V"), 2);
  const double big = 1e19;
  const std::array<double, 3> three{2.0, 1e19, -0.5};
  scalar.deliver({reinterpret_cast<const std::byte*>(&big), sizeof big});
  vec.deliver({reinterpret_cast<const std::byte*>(three.data()), sizeof three});
  auto latest = [](const dca::Port& p) {
    msgpack::sbuffer sb;
    msgpack::packer<msgpack::sbuffer> pk(sb);
    p.pack_latest(pk);
    dca::wire::Value v;
    EXPECT_TRUE(dca::wire::decode_value({sb.data(), sb.size()}, v));
    return v;
  };
  EXPECT_EQ(latest(scalar).as_float(), 1e19);
  const auto v = latest(vec);
  ASSERT_EQ(v.as_array().size(), 3u);
  EXPECT_EQ(v.as_array()[0].as_float(), 2.0);
  EXPECT_EQ(v.as_array()[1].as_float(), 1e19);
  EXPECT_EQ(v.as_array()[2].as_float(), -0.5);
}

TEST(PortTest, AVectorxInputTakesAScalarSampleAndAScalarInputRefusesThreeValues) {
  dca::Input any(dca::vectorx_port("In"), 4), one(dca::scalar_port("In"), 4);
  const Eigen::Vector3d three(1, 2, 3);
  const double half = 0.5;
  const dca::Bytes single{reinterpret_cast<const std::byte*>(&half), sizeof half};
  any.deliver(single);
  ASSERT_TRUE(any.pop());
  EXPECT_EQ(any.vector().size(), 1);
  EXPECT_EQ(any.vector()[0], 0.5);
  one.deliver({reinterpret_cast<const std::byte*>(three.data()), 3 * sizeof(double)});
  EXPECT_FALSE(one.pop());
  EXPECT_EQ(one.stats().rejected, 1u);
  one.deliver(single);
  ASSERT_TRUE(one.pop());
  EXPECT_EQ(one.scalar(), 0.5);
}

TEST(PortTest, UnknownPortErrorListsTheValidNames) {
  dca::PortSet ps;
  ps.add_input(dca::scalar_port("In1"));
  ps.add_input(dca::vector_port("Force", 6, "N"));
  EXPECT_EQ(ps.no_such_input("compliant", "In2"), "no input 'In2' on compliant; inputs are: In1, Force");
  EXPECT_EQ(ps.no_such_output("compliant", "Out"), "no output 'Out' on compliant; it has no outputs");
  EXPECT_THROW(ps.add_input(dca::scalar_port("In1")), std::invalid_argument);
}

TEST(PortTest, ChoosesTransportFromWhereTheEndsLive) {
  const dca::Location there{"b", "/tmp/x.sock", "127.0.0.1:9"};
  EXPECT_EQ(dca::choose_transport("a", true, there), dca::Transport::InProcess);
  EXPECT_EQ(dca::choose_transport("b", false, there), dca::Transport::Unix);
  EXPECT_EQ(dca::choose_transport("a", false, there), dca::Transport::Tcp);
}

TEST(PortTest, WrongSizeSampleIsRejectedAndCounted) {
  dca::Output out(dca::vector_port("Out", 3));
  EXPECT_FALSE(out.write(Eigen::VectorXd::Zero(2)));
  EXPECT_FALSE(out.write(1.0));
  EXPECT_TRUE(out.write(Eigen::Vector3d(1, 2, 3)));
  EXPECT_EQ(out.stats().rejected, 2u);
  EXPECT_EQ(out.stats().samples, 1u);
}

// A sample's bytes.
template <class T>
dca::Bytes bytes_of(const T& v) {
  return {reinterpret_cast<const std::byte*>(&v), sizeof v};
}

// What a controller's In<T>::read does (dca/port.h): one call takes the newest sample and says what it found.
TEST(PortTest, AControllersReadSaysNoneOldOrNewInOneCall) {
  dca::Input in(dca::scalar_port("x"), 4);
  double x = -1;
  EXPECT_EQ(dca::port_detail::read(in, x), dca::Read::None);
  EXPECT_EQ(x, -1);  // untouched
  in.deliver(bytes_of(1.0));
  in.deliver(bytes_of(2.0));
  EXPECT_EQ(dca::port_detail::read(in, x), dca::Read::New);
  EXPECT_EQ(x, 2);  // the newest
  x = -1;
  EXPECT_EQ(dca::port_detail::read(in, x), dca::Read::Old);
  EXPECT_EQ(x, 2);  // the last sample again
  in.deliver_pulled(bytes_of(3.0));  // a pull answer is new too
  EXPECT_EQ(dca::port_detail::read(in, x), dca::Read::New);
  EXPECT_EQ(x, 3);
  in.deliver(bytes_of(4.0));
  in.deliver(bytes_of(5.0));
  EXPECT_TRUE(dca::port_detail::pop(in, x));  // pop: in order
  EXPECT_EQ(x, 4);
  EXPECT_EQ(dca::port_detail::read(in, x), dca::Read::New);
  EXPECT_EQ(x, 5);
  EXPECT_FALSE(dca::port_detail::pop(in, x));

  dca::Input v(dca::vector_port("v", 3));
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  EXPECT_EQ(dca::port_detail::read(v, a.data(), 3), dca::Read::None);
  const Eigen::Vector3d sample(1, 2, 3);
  v.deliver({reinterpret_cast<const std::byte*>(sample.data()), 3 * sizeof(double)});
  EXPECT_EQ(dca::port_detail::read(v, a.data(), 3), dca::Read::New);
  EXPECT_EQ(a, sample);

  dca::Input vx(dca::vectorx_port("vx"));
  Eigen::VectorXd b;
  vx.deliver({reinterpret_cast<const std::byte*>(sample.data()), 2 * sizeof(double)});
  EXPECT_EQ(dca::port_detail::read(vx, b), dca::Read::New);
  EXPECT_EQ(b, Eigen::Vector2d(1, 2));
}

// A message port (docs/data-plane.md, "Typed messages"): connects to its own type only, takes its type's CDR
// (checked as it arrives), hands a controller the bytes to decode, and shows its latest as a map of fields.
TEST(PortTest, AMessagePortTakesItsTypesCdrOnly) {
  const auto twist = dca::message_port("Cmd", "geometry_msgs/msg/Twist");
  EXPECT_EQ(dca::compatibility_error(twist, dca::message_port("In", "geometry_msgs/msg/Twist")), "");
  EXPECT_EQ(dca::compatibility_error(twist, dca::message_port("In", "geometry_msgs/msg/Wrench")),
            "output 'Cmd' is geometry_msgs/msg/Twist but input 'In' is geometry_msgs/msg/Wrench");
  EXPECT_EQ(dca::compatibility_error(twist, dca::value_port("In")),
            "output 'Cmd' is geometry_msgs/msg/Twist but input 'In' is value");
  EXPECT_EQ(dca::compatibility_error(dca::vectorx_port("Out"), twist),
            "output 'Out' is vectorx but input 'Cmd' is geometry_msgs/msg/Twist");
  EXPECT_THROW(dca::Input(dca::message_port("In", "geometry_msgs/msg/Twst")), std::invalid_argument);
  EXPECT_EQ(dca::port_type_from("message"), dca::PortType::Message);

  dca::msgs::Twist t{{1, 2, 3}, {0, 0, 0.5}};
  std::array<std::byte, dca::msgs::cdr_max_size<dca::msgs::Twist>> buf{};
  const dca::Bytes cdr(buf.data(), dca::msgs::cdr_encode(t, buf));
  dca::Output out(twist);
  EXPECT_TRUE(out.write_bytes(cdr));
  EXPECT_FALSE(out.write_bytes(cdr.first(20)));  // short
  EXPECT_FALSE(out.write(1.0));
  dca::msgs::JointState js;
  js.name.resize(3);
  std::vector<std::byte> other(dca::msgs::cdr_max_size<dca::msgs::JointState>);
  other.resize(dca::msgs::cdr_encode(js, other));
  EXPECT_FALSE(out.write_bytes(other));  // another type's CDR, longer than a Twist's
  EXPECT_EQ(out.stats().rejected, 3u);

  dca::Input in(dca::message_port("In", "geometry_msgs/msg/Twist"), 2);
  dca::Bytes got;
  EXPECT_EQ(dca::port_detail::read_bytes(in, got), dca::Read::None);
  in.deliver(cdr);
  ASSERT_EQ(dca::port_detail::read_bytes(in, got), dca::Read::New);
  dca::msgs::Twist back;
  ASSERT_TRUE(dca::msgs::cdr_decode(got, back));
  EXPECT_EQ(back, t);

  msgpack::sbuffer sb;
  msgpack::packer<msgpack::sbuffer> pk(sb);
  in.pack_latest(pk);
  const auto oh = msgpack::unpack(sb.data(), sb.size());
  const auto m = oh.get().as<std::map<std::string, std::map<std::string, double>>>();
  EXPECT_EQ(m.at("linear").at("y"), 2);
  EXPECT_EQ(m.at("angular").at("z"), 0.5);
}

}  // namespace

namespace {

// A connection feeding an input, as the endpoint's links are (host/net/endpoint_internal.h).
struct FakeFeeder final : dca::InputFeeder {
  explicit FakeFeeder(std::string w) : w_(std::move(w)) {}
  void input_gone() override {}
  std::string writer() const override { return w_; }
  std::string w_;
};

// A one-double vector sample.
std::vector<std::byte> vec1(const dca::PortSpec& spec, double v) {
  dca::Output o(spec);
  o.write(Eigen::VectorXd::Constant(1, v));
  const auto b = o.latest_bytes();
  return {b.begin(), b.end()};
}

}  // namespace

// One writer at a time (docs/safety.md): the holder keeps the input for one of its periods after each sample;
// another writer's samples meanwhile are refused and named; after the holder's period, or once its connection
// is gone, another writer takes over.
TEST(PortTest, AnExclusiveInputRefusesASecondWriterWithinTheHoldersPeriod) {
  const auto spec = dca::vector_port("cmd", 1, "rad");
  dca::Input in(spec, 4);
  in.set_exclusive(50);
  FakeFeeder a("main.a.Cmd"), b("main.b.Cmd");
  in.add_feeder(&a);
  in.add_feeder(&b);
  std::vector<std::string> told;
  in.on_refused = [&](const std::string& w, const std::string& h) { told.push_back(w + " by " + h); };
  auto tick = [&](int n) {
    for (int i = 0; i < n; ++i) in.tick();
  };
  in.deliver_from(&a, vec1(spec, 1.0));  // a holds it: one tick before its second sample
  in.deliver_from(&b, vec1(spec, 2.0));  // the same tick: refused
  ASSERT_TRUE(in.take_latest());
  EXPECT_EQ(in.vector()[0], 1.0);
  EXPECT_EQ(in.refused(), 1u);
  tick(10);
  in.deliver_from(&a, vec1(spec, 1.5));  // a every 10 ticks: its period is 10
  tick(5);
  in.deliver_from(&b, vec1(spec, 2.0));  // interleaved, 5 ticks after a's: refused
  EXPECT_EQ(in.refused(), 2u);
  ASSERT_TRUE(in.take_latest());
  EXPECT_EQ(in.vector()[0], 1.5);
  tick(5);
  in.deliver_from(&b, vec1(spec, 2.5));  // a's period has passed without a sample: b takes over
  ASSERT_TRUE(in.take_latest());
  EXPECT_EQ(in.vector()[0], 2.5);
  EXPECT_EQ(in.refused(), 2u);
  in.deliver_from(&a, vec1(spec, 1.0));  // now a is the second writer
  EXPECT_EQ(in.refused(), 3u);
  in.remove_feeder(&b);                  // b's connection is gone: a may write at once
  in.deliver_from(&a, vec1(spec, 0.5));
  ASSERT_TRUE(in.take_latest());
  EXPECT_EQ(in.vector()[0], 0.5);
  EXPECT_EQ(told, (std::vector<std::string>{"main.b.Cmd by main.a.Cmd", "main.b.Cmd by main.a.Cmd",
                                            "main.a.Cmd by main.b.Cmd"}));
  in.remove_feeder(&a);
}

// Two inputs of one actuator (Input::share_exclusive: a joint's alias beside its drive's vector): a writer on
// either holds both, the other input's writer is refused; the shared hold's clock is the owner's ticks only.
TEST(PortTest, InputsSharingAnActuatorsHoldTakeOneWriterBetweenThem) {
  const auto vspec = dca::vector_port("arm.cmd_qd", 1, "rad/s"), aspec = dca::vector_port("joint.j.cmd", 1, "rad/s");
  dca::Input vector_in(vspec, 4), alias_in(aspec, 4);
  vector_in.set_exclusive(50);
  alias_in.set_exclusive(50);
  alias_in.share_exclusive(vector_in);
  FakeFeeder a("main.drive.Cmd"), b("main.j.Cmd");
  vector_in.add_feeder(&a);
  alias_in.add_feeder(&b);
  std::vector<std::string> told;
  alias_in.on_refused = [&](const std::string& w, const std::string& h) { told.push_back(w + " by " + h); };
  vector_in.deliver_from(&a, vec1(vspec, 1.0));  // a holds the actuator
  alias_in.deliver_from(&b, vec1(aspec, 2.0));   // the same tick, on the other input: refused
  EXPECT_EQ(alias_in.refused(), 1u);
  EXPECT_FALSE(alias_in.take_latest());
  EXPECT_EQ(told, (std::vector<std::string>{"main.j.Cmd by main.drive.Cmd"}));
  alias_in.tick();  // not the hold's owner: its clock does not move
  alias_in.deliver_from(&b, vec1(aspec, 2.0));
  EXPECT_EQ(alias_in.refused(), 2u);
  vector_in.tick();  // one tick of the owner: a's lease (one tick before its second sample) is over
  alias_in.deliver_from(&b, vec1(aspec, 2.5));
  ASSERT_TRUE(alias_in.take_latest());
  EXPECT_EQ(alias_in.vector()[0], 2.5);
  vector_in.deliver_from(&a, vec1(vspec, 1.0));  // now a is the second writer, on its own input
  EXPECT_EQ(vector_in.refused(), 1u);
  alias_in.remove_feeder(&b);                    // b's connection gone: a takes the actuator at once
  vector_in.deliver_from(&a, vec1(vspec, 0.5));
  ASSERT_TRUE(vector_in.take_latest());
  EXPECT_EQ(vector_in.vector()[0], 0.5);
  vector_in.remove_feeder(&a);
}

// Not exclusive (every other input): many writers, every sample taken.
TEST(PortTest, AnInputThatIsNotExclusiveTakesEveryWriter) {
  const auto spec = dca::vector_port("in", 1, "");
  dca::Input in(spec, 4);
  FakeFeeder a("a.Out"), b("b.Out");
  in.deliver_from(&a, vec1(spec, 1.0));
  in.deliver_from(&b, vec1(spec, 2.0));
  EXPECT_EQ(in.queued(), 2u);
  EXPECT_EQ(in.refused(), 0u);
}

// A restart's new connection under the same name (the same link key) resets the reader's gate. The old
// connection's last sample may still arrive after the new one's hello (two sockets, read in whatever order):
// it is dropped, never counted or delivered as the new connection's (docs/time.md, "A restart" 11). Before,
// it was: a restarted drive's first command read as its old process's last (scenario door_drive_restart, 1 run
// in many under load).
TEST(PortTest, AGateDropsTheSamplesOfTheConnectionItsNewOneReplaced) {
  const auto spec = dca::vector_port("cmd", 1, "m/s");
  FakeFeeder old_link("main.xr.Cmd"), new_link("main.xr.Cmd");  // (before the input: it tells them it is gone)
  dca::Input in(spec, 4);
  in.add_feeder(&old_link);
  dca::LinkGate gate;
  gate.gated = true;
  gate.adopt(&old_link);
  gate.deliver(in, vec1(spec, 0.25), &old_link);
  EXPECT_TRUE(gate.release(&in, 1));
  EXPECT_EQ(in.queued(), 1u);
  in.pop();

  // the restart: the new connection's hello resets the gate and takes it
  gate.reset();
  gate.adopt(&new_link);
  in.add_feeder(&new_link);
  gate.deliver(in, vec1(spec, 0.25), &old_link);  // the old process's last, late
  EXPECT_EQ(gate.received(), 0u) << "not counted as the new connection's";
  EXPECT_EQ(gate.stale(), 1u);
  EXPECT_FALSE(gate.release(&in, 1)) << "the new connection's first sample has not come";
  EXPECT_EQ(in.queued(), 0u);
  gate.deliver(in, vec1(spec, 0.0), &new_link);
  EXPECT_EQ(in.queued(), 1u) << "released on arrival: its count was allowed";
  ASSERT_TRUE(in.pop());
  EXPECT_EQ(in.current_bytes().size(), sizeof(double));
  double v = -1;
  std::memcpy(&v, in.current_bytes().data(), sizeof v);
  EXPECT_EQ(v, 0.0) << "the new connection's own sample";
}
