// The ros2 bridge's round trip against a plain Cyclone DDS ping-pong of the same type, in the same run
// (docs/ros2.md). Everything in one process and one DDS domain (Cyclone delivers locally: no network), so the
// difference is the bridge's own: its port, its CDR encode and decode, its DDS thread and queue, its period.
//   plain:  a writer -> an echo (its own participant and thread) -> a reader woken by a waitset
//   bridge: In<M> -> ros2_bridge -> the same echo -> the bridge's DDS thread -> its queue -> Out<M>, the bridge
//           stepped as fast as the harness can (dca/testing/controller.h: simulated time; MainCalc per step)
// Two messages: sensor_msgs/JointState of six joints, std_msgs/Float64MultiArray of six values (64 bytes of CDR).
//   RESULT bench=ros2_bridge variant=<plain|bridge>_<type> n=.. p50_us=.. ... [ratio=bridge/plain p50]
//   build/release/bench/bench_ros2_bridge [ROUNDS]     (default 2000)
#include <dca/testing/controller.h>

#include <unistd.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "bench_util.h"
#include "bridge.h"
#include "dds.h"

namespace {

using dca::msgs::Float64MultiArray;
using dca::msgs::JointState;
using dca::ros2::Endpoint;
using dca::ros2::Participant;
using Clock = std::chrono::steady_clock;

dca::ros2::ParticipantOptions options() {
  return {.domain = static_cast<std::uint32_t>(1 + getpid() % 230), .interface = "lo", .peers = "127.0.0.1"};
}

// Reads `ping` and writes each sample's bytes back on `pong`, on its own thread, until destroyed.
class Echo {
 public:
  Echo(const std::string& ping, const std::string& pong, std::string_view type)
      : p_(options()), ws_(p_), stop_(false) {
    const auto q = *dca::ros2::qos_profile("default");
    in_ = p_.reader(ping, type, "", q);
    out_ = p_.writer(pong, type, "", q);
    ws_.add(in_);
    thread_ = std::thread([this] {
      while (!stop_.load()) {
        ws_.wait(100);
        dca::ros2::take(in_, [this](std::span<const std::byte> cdr) { dca::ros2::write(out_, cdr); });
      }
    });
  }
  ~Echo() {
    stop_ = true;
    ws_.wake();
    thread_.join();
  }

 private:
  Participant p_;
  dca::ros2::WaitSet ws_;
  Endpoint in_, out_;
  std::atomic<bool> stop_;
  std::thread thread_;
};

template <class M>
void plain(const M& m, int rounds, std::vector<double>& us) {
  const std::string ping = "rt/bench_plain_ping", pong = "rt/bench_plain_pong";
  Echo echo(ping, pong, M::dds_name);
  Participant p(options());
  const auto q = *dca::ros2::qos_profile("default");
  Endpoint w = p.writer(ping, M::dds_name, "", q), r = p.reader(pong, M::dds_name, "", q);
  dca::ros2::WaitSet ws(p);
  ws.add(r);
  std::array<std::byte, dca::msgs::cdr_max_size<M>> buf;
  const std::size_t n = dca::msgs::cdr_encode(m, buf);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // discovery (a benchmark, not a test)
  for (int i = 0; i < rounds; ++i) {
    const auto t0 = Clock::now();
    dca::ros2::write(w, std::span(buf).first(n));
    std::size_t got = 0;
    while (got == 0) {
      ws.wait(1000);
      got = dca::ros2::take(r, [](std::span<const std::byte>) {});
    }
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
}

template <class M>
void bridged(const M& m, int rounds, std::vector<double>& us) {
  const std::string short_name(M::ros_name.substr(M::ros_name.rfind('/') + 1));
  Echo echo("rt/bench_bridge_ping", "rt/bench_bridge_pong", M::dds_name);
  const auto o = options();
  const std::string type(M::ros_name);
  dca::testing::ControllerUnderTest c(
      "ros2_bridge", {"/bench_bridge_ping " + type + " pub; /bench_bridge_pong " + type + " sub", "dca_bench",
                      std::to_string(o.domain), o.interface, o.peers, "", "0.001"});
  c.start();
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // discovery
  const std::string in = "Pub" + short_name + "0", out = "Sub" + short_name + "0";
  for (int i = 0; i < rounds; ++i) {
    const std::uint64_t before = c.writes(out);
    const auto t0 = Clock::now();
    c.set_message(in, m);
    while (c.writes(out) == before) c.step();
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  c.halt();
}

template <class M>
void compare(const char* name, const M& m, int rounds) {
  std::vector<double> a, b;
  plain(m, rounds, a);
  bridged(m, rounds, b);
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  const double ratio = dca::bench::quantile(b, 0.5) / dca::bench::quantile(a, 0.5);
  const std::string bytes = " cdr_bytes=" + std::to_string(dca::msgs::cdr_size(m));
  dca::bench::result("ros2_bridge", std::string("plain_") + name, a, bytes);
  dca::bench::result("ros2_bridge", std::string("bridge_") + name, b, bytes + " ratio=" + std::to_string(ratio));
}

}  // namespace

int main(int argc, char** argv) {
  const int rounds = argc > 1 ? std::atoi(argv[1]) : 2000;
  JointState js;
  for (const char* n : {"shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
                        "wrist_2_joint", "wrist_3_joint"}) {
    dca::msgs::Name name;
    name.assign(n);
    js.name.push_back(name);
    js.position.push_back(0.1);
    js.velocity.push_back(0.2);
    js.effort.push_back(0.3);
  }
  Float64MultiArray a;
  for (int i = 0; i < 6; ++i) a.data.push_back(i);
  compare("joint_state", js, rounds);
  compare("float64x6", a, rounds);
  return 0;
}
