#pragma once
// Worlds built from a URDF file (docs/robots.md): the Simbody world (`--sim ROBOT.urdf`) and the mock hardware
// (`--sim mock:ROBOT.urdf`), both a DeviceWorld whose ports are the joints' interfaces (sim/urdf/joint_interfaces.h)
// behind the same safety layer. C++17-clean.
//
// World spec (what `dca run --sim SPEC` and `dca sim --world SPEC` take):
//   ROBOT.urdf                                 the Simbody world of the robot, its root link fixed to the ground
//   mock:ROBOT.urdf[?lag=S&dead=J1,J2]          mock hardware: states mirror the commands, through a first-order
//                                              lag of time constant S (default 0: at once); the drives of joints
//                                              J1, J2 are dead (their commands are taken, clamped and counted,
//                                              and ignored: the joint stays where it is)
#include <memory>
#include <string>
#include <vector>

#include "host/codec/frames.h"
#include "sim/device_world.h"
#include "sim/urdf/joint_interfaces.h"
#include "sim/urdf/sensors.h"

namespace dca::sim {

/// A parsed world spec (see the file comment).
struct RobotWorldSpec {
  std::string file;                ///< the URDF file
  bool mock = false;
  double lag = 0;                  ///< mock: s, the states' time constant (0: the commands at once)
  std::vector<std::string> dead;   ///< mock: joints whose drives ignore their commands
};

/// Whether `spec` names a URDF world (ends in .urdf, with or without mock: and options), rather than "door".
bool is_robot_world(const std::string& spec);
/// Parses `spec`: false with *error saying what is wrong.
bool parse_world_spec(const std::string& spec, RobotWorldSpec* out, std::string* error);

/// The parts common to the URDF worlds: the ports, the safety layer, the status and the summary. A world
/// implements advance(): one period under the drives of interfaces(), updating state().
class JointWorld : public DeviceWorld {
 public:
  JointWorld(RobotDescription description, double period);
  double period() const override { return period_; }
  double time() const override { return static_cast<double>(tick_) * period_; }
  const std::vector<DeviceSignal>& sensors() const override { return sensors_; }
  const std::vector<DeviceSignal>& commands() const override { return commands_; }
  void command(std::size_t i, const double* v, std::size_t n) override;
  void writer_gone(std::size_t i) override { interfaces_.writer_gone(i); }
  void estop(bool latched) override { interfaces_.estop(latched); }
  void step() override;
  void sensor(std::size_t i, double* out) const override;
  void status(StatusSink& sink) const override;
  std::string describe() const override;
  std::vector<std::string> summary() const override;
  std::vector<std::string> warnings() const override { return description_.warnings; }

  const RobotDescription& description() const { return description_; }
  const JointInterfaces& interfaces() const { return interfaces_; }
  const std::vector<JointState>& state() const { return state_; }
  long ticks() const { return tick_; }
  /// The link frames (sim/urdf/frames.h): the output links.frames, in its order.
  const std::vector<frames::Frame>& frames() const override { return frames_; }
  std::string robot_description() const override { return description_.text; }
  /// Their values now: 7 per frame into `out` (each link in its parent link's frame).
  virtual void link_frames(double* out) const = 0;

 protected:
  /// Every sensor's reading now (sim/urdf/sensors.h: sensor_values(kind) each, in description order).
  virtual void read_sensors(std::vector<double>& out) const = 0;
  virtual void advance() = 0;
  virtual std::string kind() const = 0;
  /// The world's own status fields and summary lines.
  virtual void more_status(StatusSink&) const {}
  virtual void more_summary(std::vector<std::string>&) const {}

  RobotDescription description_;
  JointInterfaces interfaces_;
  std::vector<JointState> state_;

 private:
  double period_;
  long tick_ = 0;
  std::vector<DeviceSignal> sensors_, commands_;
  std::vector<frames::Frame> frames_;
  std::size_t first_sensor_port_ = 0;        // sensors_: the sensors' ports come last
  std::vector<SensorPort> sensor_ports_;
  std::vector<std::size_t> sensor_offset_;   // per sensor: where its reading starts in readings_
  mutable std::vector<double> readings_;     // read once per step, when a sensor port is first read
  mutable long readings_tick_ = -1;
};

/// The Simbody world of `description` (sim/urdf/urdf_world.cpp). Throws UrdfError when Simbody rejects it.
std::unique_ptr<JointWorld> make_simbody_world(RobotDescription description, double period);
/// The mock hardware of `description`.
std::unique_ptr<JointWorld> make_mock_world(RobotDescription description, double period, double lag,
                                            const std::vector<std::string>& dead);
/// The world `spec` names, its URDF loaded. Throws UrdfError (the file) or std::invalid_argument (the spec).
std::unique_ptr<JointWorld> make_robot_world(const std::string& spec, double period);

/// The index of the signal named `name` in `signals`, or signals.size().
std::size_t signal_index(const std::vector<DeviceSignal>& signals, const std::string& name);

}  // namespace dca::sim
