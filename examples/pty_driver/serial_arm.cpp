// SerialArm: the driver of a six-joint arm on a serial line (a pseudo-terminal here: device/pty_arm.cpp), the robot
// of a run in wall-clock time (docs/drivers.md). Its ports are the arm's device signals, named as the URDF world
// names them (dca/robot/joints.h), so `dca run FILE.dca --driver 'pty_driver.SerialArm("arm", "/dev/pts/N")'`
// wires every leaf's device ports to it as to `--sim ur10.urdf`:
//   out joint.J.position, .velocity, .effort   vector[1]   the latest valid state line (rad, rad/s, N m)
//   in  joint.J.position_command               vector[1]   a position target (rad)
//   in  joint.J.velocity_command               vector[1]   a velocity target (rad/s)
//   out safety.clamps, safety.stale            vector[12]  per command input (in input order): samples clamped or
//                                                           dropped, times gone stale (as the URDF world's)
//   out device.lines                           vector[4]   lines read: valid, bad checksum, garbled, overlong
// Each tick (period) it reads what the arm sent, publishes the newest state when one came, takes the
// newest command of each joint (the interface whose sample came last is in force), applies its watchdog (a
// command older than `watchdog` s is stale: a position target holds, a velocity becomes 0) and its limits, and
// sends one command line per commanded joint. No valid state line for `timeout` s: ABORTED, naming the device and what came instead.
#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include <dca/controller.h>
#include <dca/registry.h>
#include <dca/robot/joints.h>

#include "arm.h"
#include "protocol.h"

namespace pty_driver {

namespace {

using Vec1 = Eigen::Matrix<double, 1, 1>;
using Counts = Eigen::Matrix<double, 2 * kJoints, 1>;
using Lines = Eigen::Matrix<double, 4, 1>;

const char* const kStates[] = {"position", "velocity", "effort"};
const char* const kStateUnits[] = {"rad", "rad/s", "N m"};

// Per joint: position, velocity, effort (3 * joint + k).
std::vector<dca::OutSpec<Vec1>> state_specs() {
  std::vector<dca::OutSpec<Vec1>> v;
  for (const auto& j : kArm)
    for (int k = 0; k < 3; ++k)
      v.push_back({.name = dca::robot::joint_state_signal(j.name, kStates[k]), .units = kStateUnits[k]});
  return v;
}
// Per joint: position_command, velocity_command (2 * joint + k).
std::vector<dca::InSpec<Vec1>> command_specs() {
  std::vector<dca::InSpec<Vec1>> v;
  for (const auto& j : kArm) {
    v.push_back({.name = dca::robot::joint_command_signal(j.name, "position"), .units = "rad"});
    v.push_back({.name = dca::robot::joint_command_signal(j.name, "velocity"), .units = "rad/s"});
  }
  return v;
}
const std::vector<dca::OutSpec<Vec1>> kStateOuts = state_specs();
const std::vector<dca::InSpec<Vec1>> kCommandIns = command_specs();
const dca::OutSpec<Counts> kClamps{.name = "safety.clamps", .units = "samples"};
const dca::OutSpec<Counts> kStale{.name = "safety.stale", .units = "times"};
const dca::OutSpec<Lines> kLines{.name = "device.lines", .units = "lines"};
const dca::Param<std::string> kDevice{.name = "device", .doc = "the serial port's path (the pty's slave side)"};
const dca::Param<double> kWatchdog{.name = "watchdog",
                                   .doc = "s: a command older than this is stale (position holds, velocity 0)",
                                   .def = 0.1,
                                   .above = 0};
const dca::Param<double> kTimeout{
    .name = "timeout", .doc = "s: ABORTED after this long without a valid state line", .def = 1, .above = 0};

}  // namespace

class SerialArm final : public dca::PeriodicController {
  DCA_CONTROLLER(SerialArm)
 public:
  ~SerialArm() override { close_device(); }

 private:
  // A joint's command: the interface in force ('P', 'V', or 0 before any), its value after the limits, when it came.
  struct Joint {
    char mode = 0;
    double value = 0;
    dca::Nanos at = 0;
    bool stale = false;
  };

  void on_configure() override;
  void MainCalc() override;
  void on_halt() override;
  bool read_device();
  void take_commands();
  void send(const Command& c);
  std::string what_came() const;
  void close_device() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

  std::vector<dca::Out<Vec1>> states_;
  std::vector<dca::In<Vec1>> commands_;
  dca::Out<Counts> clamps_out_;
  dca::Out<Counts> stale_out_;
  dca::Out<Lines> lines_out_;
  std::string device_;
  dca::Nanos watchdog_, timeout_;
  int fd_ = -1;
  LineReader reader_;
  pty_driver::State arm_;  // the newest valid state
  dca::Nanos last_state_ = 0;
  std::array<Joint, kJoints> joints_{};
  Counts clamps_ = Counts::Zero(), stale_ = Counts::Zero();
  Lines lines_ = Lines::Zero();  // valid, bad checksum, garbled, overlong
  int read_errno_ = 0;           // the last read error (0: none)
  bool hangup_ = false;          // the other side closed
};

dca::Manifest SerialArm::Describe() {
  dca::Manifest m{.type = "SerialArm",
                  .doc = "the driver of a six-joint arm on a serial line: its joints as device signals",
                  .outputs = {kClamps, kStale, kLines},
                  .params = {kDevice, kWatchdog, kTimeout, PeriodParam()},
                  .ends = dca::Ending::Aborted()};
  for (const auto& s : kStateOuts) m.outputs.push_back(s);
  for (const auto& s : kCommandIns) m.inputs.push_back(s);
  return m;
}

SerialArm::SerialArm(const dca::ControllerContext& ctx)
    : PeriodicController(ctx), clamps_out_(port(kClamps)), stale_out_(port(kStale)), lines_out_(port(kLines)),
      device_(param(kDevice)), watchdog_(dca::from_seconds(param(kWatchdog))),
      timeout_(dca::from_seconds(param(kTimeout))) {
  for (const auto& s : kStateOuts) states_.push_back(port(s));
  for (const auto& s : kCommandIns) commands_.push_back(port(s));
}

// Opens the serial port raw and non-blocking (again before every run); throws naming it when it cannot.
void SerialArm::on_configure() {
  close_device();
  fd_ = ::open(device_.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) throw std::runtime_error("cannot open the device " + device_ + ": " + std::strerror(errno));
  termios t{};
  if (::isatty(fd_) && ::tcgetattr(fd_, &t) == 0) {
    ::cfmakeraw(&t);
    ::tcsetattr(fd_, TCSANOW, &t);
    ::tcflush(fd_, TCIFLUSH);  // what the arm said before we listened is old
  }
  reader_.reset();
  last_state_ = 0;
  joints_ = {};
  read_errno_ = 0;
  hangup_ = false;
}

void SerialArm::MainCalc() {
  const dca::Nanos now_ns = now();
  if (last_state_ < started()) last_state_ = started();
  if (read_device()) {  // a new state: published (an old one never again)
    for (std::size_t j = 0; j < kJoints; ++j) {
      states_[3 * j].write(Vec1(arm_.q[j]));
      states_[3 * j + 1].write(Vec1(arm_.qd[j]));
      states_[3 * j + 2].write(Vec1(arm_.effort[j]));
    }
  }
  take_commands();
  clamps_out_.write(clamps_);
  stale_out_.write(stale_);
  lines_out_.write(lines_);
  if (now_ns - last_state_ > timeout_)
    Abort("the device " + device_ + " sent no valid state line for " + dca::format_number(dca::to_seconds(timeout_)) +
          " s (" + what_came() + ")");
}

// Everything the arm sent since the last tick, line by line; the newest valid state kept. --> whether one came
bool SerialArm::read_device() {
  std::array<char, 4096> buf;
  bool fresh = false;
  for (int reads = 0; reads < 16; ++reads) {  // bounded: a babbling device cannot hold the tick
    const ssize_t n = ::read(fd_, buf.data(), buf.size());
    if (n == 0) hangup_ = true;
    if (n < 0 && errno != EAGAIN && errno != EINTR) read_errno_ = errno;
    if (n <= 0) break;
    reader_.feed(buf.data(), static_cast<std::size_t>(n), [this, &fresh](std::string_view line) {
      const LineError e = parse_state(line, &arm_);
      lines_[e == LineError::none ? 0 : (e == LineError::checksum ? 1 : 2)] += 1;
      if (e == LineError::none) fresh = true, last_state_ = now();
    });
  }
  lines_[3] = static_cast<double>(reader_.overlong());
  return fresh;
}

// The newest sample of each command input, through the watchdog and the limits, sent to the arm.
void SerialArm::take_commands() {
  const dca::Nanos now_ns = now();
  for (std::size_t j = 0; j < kJoints; ++j) {
    Joint& jt = joints_[j];
    for (std::size_t k = 0; k < 2; ++k) {
      Vec1 v;
      if (commands_[2 * j + k].read(v) != dca::Read::New) continue;
      const std::size_t input = 2 * j + k;
      if (!std::isfinite(v[0])) {  // dropped and counted; the command before it stays
        clamps_[static_cast<Eigen::Index>(input)] += 1;
        continue;
      }
      const double lo = k == 0 ? kArm[j].lower : -kArm[j].velocity;
      const double hi = k == 0 ? kArm[j].upper : kArm[j].velocity;
      const double x = std::clamp(v[0], lo, hi);
      if (x != v[0]) clamps_[static_cast<Eigen::Index>(input)] += 1;
      jt = {.mode = k == 0 ? 'P' : 'V', .value = x, .at = now_ns, .stale = false};
    }
    if (jt.mode == 0) continue;
    if (!jt.stale && now_ns - jt.at > watchdog_) {
      jt.stale = true;
      stale_[static_cast<Eigen::Index>(2 * j + (jt.mode == 'P' ? 0 : 1))] += 1;
    }
    // stale: a position target holds (sent again), a velocity is 0
    send({.joint = j, .mode = jt.mode, .value = jt.stale && jt.mode == 'V' ? 0.0 : jt.value});
  }
}

void SerialArm::send(const Command& c) {
  std::array<char, kMaxLine + 1> line;
  const std::size_t n = format_command(c, line.data(), line.size());
  // a full line or nothing: a port that takes no more this tick gets the command again next tick
  if (n > 0 && fd_ >= 0) (void)!::write(fd_, line.data(), n);
}

// Stopped: every velocity-commanded joint is told 0 (a position target holds on the arm), the port closed.
void SerialArm::on_halt() {
  for (std::size_t j = 0; j < kJoints; ++j)
    if (joints_[j].mode == 'V') send({.joint = j, .mode = 'V', .value = 0});
  close_device();
}

// "lines: 12 with a bad checksum, 0 garbled, 0 too long; read: Input/output error"
std::string SerialArm::what_came() const {
  std::string s = "lines: " + std::to_string(static_cast<long>(lines_[1])) + " with a bad checksum, " +
                  std::to_string(static_cast<long>(lines_[2])) + " garbled, " +
                  std::to_string(static_cast<long>(lines_[3])) + " too long";
  if (read_errno_ != 0) s += "; read: " + std::string(std::strerror(read_errno_));
  if (hangup_) s += "; the other side closed";
  return s;
}

DCA_REGISTER_CONTROLLER(SerialArm);

}  // namespace pty_driver
