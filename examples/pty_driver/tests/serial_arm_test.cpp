// SerialArm alone (dca/testing/controller.h) on a pseudo-terminal this test opens and plays the arm on: what it
// publishes from the arm's lines, the commands it sends, its limits, its watchdog, and a missing or silent arm.
// Waits are on the pty (poll, 5 s at most), never sleeps.
#include <dca/testing/controller.h>

#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <string>

#include "protocol.h"

using dca::testing::ControllerUnderTest;
using namespace pty_driver;

namespace {

// A pty: its master (the test, playing the arm) and a second reader of its slave side, to wait on.
struct Pty {
  int master = -1, slave = -1;
  std::string path;
  Pty() {
    master = posix_openpt(O_RDWR | O_NOCTTY);
    std::array<char, 128> name{};
    if (master < 0 || grantpt(master) != 0 || unlockpt(master) != 0 || ptsname_r(master, name.data(), name.size()))
      std::abort();
    path = name.data();
    slave = open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
    termios t{};
    tcgetattr(slave, &t);
    cfmakeraw(&t);
    tcsetattr(slave, TCSANOW, &t);
  }
  ~Pty() {
    close(slave);
    close(master);
  }
  // Writes to the arm's side and waits until the driver's side can read it.
  void say(const std::string& text) const {
    ASSERT_EQ(write(master, text.data(), text.size()), static_cast<ssize_t>(text.size()));
    pollfd p{slave, POLLIN, 0};
    ASSERT_EQ(poll(&p, 1, 5000), 1) << "the pty did not pass the line on within 5 s";
  }
  // The first `lines` lines the driver sent (each command is a write of its own, so one read may hold only the
  // first), waiting at most 5 s for them.
  std::string heard(int lines) const {
    std::string got;
    std::array<char, 4096> buf;
    while (std::count(got.begin(), got.end(), '\n') < lines) {
      pollfd p{master, POLLIN, 0};
      if (poll(&p, 1, 5000) != 1) break;
      const ssize_t n = read(master, buf.data(), buf.size());
      if (n <= 0) break;
      got.append(buf.data(), static_cast<std::size_t>(n));
    }
    return got;
  }
};

std::string state_line(double elbow) {
  State s;
  s.t_ms = 7;
  for (std::size_t j = 0; j < kJoints; ++j) s.q[j] = kArm[j].start;
  s.q[2] = elbow;
  s.qd[2] = 0.5;
  std::array<char, kMaxLine + 1> buf;
  return std::string(buf.data(), format_state(s, buf.data(), buf.size()));
}

Eigen::VectorXd one(double x) { return Eigen::VectorXd::Constant(1, x); }

}  // namespace

TEST(SerialArm, PublishesTheNewestValidStateAndCountsTheRest) {
  Pty pty;
  ControllerUnderTest d("SerialArm", {pty.path});
  d.start();
  std::string noise = state_line(0.5);
  noise[12] = static_cast<char>(noise[12] ^ 1);
  pty.say(state_line(0.25) + noise + "S 1 2*50\n" + std::string(kMaxLine + 1, 'x') + "\n" + "S 2 partial");
  d.step();
  EXPECT_EQ(d.get_vector("joint.elbow_joint.position")[0], 0.25);
  EXPECT_EQ(d.get_vector("joint.elbow_joint.velocity")[0], 0.5);
  EXPECT_NEAR(d.get_vector("joint.shoulder_lift_joint.position")[0], kArm[1].start, 1e-8);  // 9 digits
  const Eigen::VectorXd lines = d.get_vector("device.lines");  // valid, bad checksum, garbled, overlong
  EXPECT_EQ(lines[0], 1);
  EXPECT_EQ(lines[1], 1);
  EXPECT_EQ(lines[2], 1);
  EXPECT_EQ(lines[3], 1);
  EXPECT_FALSE(d.ended());
}

TEST(SerialArm, SendsCommandsWithinTheLimitsAndCountsEachClamp) {
  Pty pty;
  ControllerUnderTest d("SerialArm", {pty.path});
  d.start();
  d.set("joint.elbow_joint.position_command", one(10.0));  // past the elbow's soft limit 3.0916
  d.set("joint.wrist_1_joint.velocity_command", one(-0.5));
  d.step();
  const std::string sent = pty.heard(2);
  EXPECT_NE(sent.find("C 2 P 3.09159265*"), std::string::npos) << sent;
  EXPECT_NE(sent.find("C 3 V -0.5*"), std::string::npos) << sent;
  EXPECT_EQ(sent.find("C 0 "), std::string::npos) << "a joint never commanded is left to the arm: " << sent;
  const Eigen::VectorXd clamps = d.get_vector("safety.clamps");  // per input: J0 position, J0 velocity, J1 ...
  EXPECT_EQ(clamps[4], 1);
  EXPECT_EQ(clamps.sum(), 1);
  d.set("joint.elbow_joint.position_command", one(std::nan("")));  // dropped, counted; 3.0916 stays
  d.step();
  EXPECT_EQ(d.get_vector("safety.clamps")[4], 2);
}

TEST(SerialArm, AStaleVelocityBecomesZeroAndAStalePositionHolds) {
  Pty pty;
  ControllerUnderTest d("SerialArm", {pty.path, "0.05"});  // watchdog 0.05 s
  d.start();
  d.set("joint.elbow_joint.position_command", one(1.0));
  d.set("joint.wrist_1_joint.velocity_command", one(-0.5));
  pty.say(state_line(0));  // (so that the arm is not taken for dead)
  d.step();
  (void)pty.heard(2);
  d.advance(0.06);
  tcflush(pty.master, TCIFLUSH);  // what came before going stale
  d.step();
  const std::string sent = pty.heard(2);
  EXPECT_NE(sent.find("C 3 V 0*"), std::string::npos) << sent;
  EXPECT_NE(sent.find("C 2 P 1*"), std::string::npos) << sent;
  const Eigen::VectorXd stale = d.get_vector("safety.stale");
  EXPECT_EQ(stale[4], 1);  // elbow position: once, however long it stays stale
  EXPECT_EQ(stale[7], 1);  // wrist 1 velocity
  EXPECT_EQ(stale.sum(), 2);
}

TEST(SerialArm, ASilentArmEndsTheRunNamingTheDevice) {
  Pty pty;
  ControllerUnderTest d("SerialArm", {pty.path, "0.1", "0.5"});  // timeout 0.5 s
  d.start();
  pty.say("garbage\n");
  d.advance(0.6);
  ASSERT_TRUE(d.ended());
  EXPECT_FALSE(d.ended()->done);
  EXPECT_NE(d.ended()->reason.find("the device " + pty.path + " sent no valid state line for 0.5"), std::string::npos)
      << d.ended()->reason;
  EXPECT_NE(d.ended()->reason.find("lines: 1 with a bad checksum, 0 garbled"), std::string::npos) << d.ended()->reason;
}

TEST(SerialArm, AMissingDeviceIsNamedWhenItStarts) {
  ControllerUnderTest d("SerialArm", {"/nonexistent/tty"});
  try {
    d.start();
    FAIL() << "started without its device";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open the device /nonexistent/tty: No such file"), std::string::npos)
        << e.what();
  }
}
