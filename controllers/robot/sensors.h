#pragma once
// The robot's sensors. Each ticks every `period` (default 0.01 s) and passes the newest sample of its device
// input to its output:
//
// XR4000Odometry(host, period)  the base's odometry (Nomad XR4000)
//   in  Odom      vector[3] device base.pose        out Pose     vector[3] x, y (m), yaw (rad) in the world
// Puma560Joints(host, period)   the arm's joint angles (Puma 560)
//   in  Q         vector[6] device arm.q            out Joints   vector[6] joint angles (rad)
// ForceTorque(host, period)     the wrist force/torque sensor
//   in  Raw       vector[6] device wrist.wrench     out Wrench   vector[6] N, N m (sensor frame)
// HandleCamera(host, period)    the camera's tracker of the door handle's grasp point
//   in  Raw       vector[3] device camera.handle    out Feature  vector[3] u, v (pixels), visible (1/0)
// LaserSensor(host, period)     the laser range finder facing forward from the base
//   in  Raw       vector[1] device laser.range      out Distance scalar    m to the door's plane
#include <string_view>

#include <dca/robot/signals.h>

namespace dca::robot {

/// What tells one pass-through sensor from another: its manifest.
struct SensorSpec {
  std::string_view type, doc;
  std::string_view input, output, units, signal;  ///< the device input, the output, both ports' units
};

/// A pass-through sensor: copies each new vector[N] sample of its device input to its output.
template <int N, const SensorSpec& S>
class Sensor final : public PeriodicController {
 public:
  using Vec = Eigen::Matrix<double, N, 1>;
  static InSpec<Vec> in_spec() {
    return {.name = std::string(S.input), .units = std::string(S.units), .device = std::string(S.signal)};
  }
  static OutSpec<Vec> out_spec() { return {.name = std::string(S.output), .units = std::string(S.units)}; }
  static Manifest Describe() {
    return {.type = std::string(S.type), .doc = std::string(S.doc), .inputs = {in_spec()}, .outputs = {out_spec()},
            .params = {PeriodParam()}, .ends = Ending::Never()};
  }
  explicit Sensor(const ControllerContext& ctx) : PeriodicController(ctx), in_(port(in_spec())), out_(port(out_spec())) {}

 private:
  void MainCalc() override {
    if (in_.read(v_) == Read::New) out_.write(v_);
  }

  dca::In<Vec> in_;
  dca::Out<Vec> out_;
  Vec v_ = Vec::Zero();
};

inline constexpr SensorSpec kXR4000Odometry{"XR4000Odometry", "the base's odometry (Nomad XR4000)",
                                            "Odom", "Pose", "m, m, rad", "base.pose"};
inline constexpr SensorSpec kPuma560Joints{"Puma560Joints", "the arm's joint angles (Puma 560)",
                                           "Q", "Joints", "rad", "arm.q"};
inline constexpr SensorSpec kForceTorque{"ForceTorque", "the wrist force/torque sensor",
                                         "Raw", "Wrench", "N, N m", "wrist.wrench"};
inline constexpr SensorSpec kHandleCamera{"HandleCamera", "the camera's tracker of the door handle's grasp point",
                                          "Raw", "Feature", "px, px, 1", "camera.handle"};

using XR4000Odometry = Sensor<3, kXR4000Odometry>;
using Puma560Joints = Sensor<6, kPuma560Joints>;
using ForceTorque = Sensor<6, kForceTorque>;
using HandleCamera = Sensor<3, kHandleCamera>;

/// The laser range finder: its device signal is a vector[1], its output a scalar.
class LaserSensor final : public PeriodicController {
  DCA_CONTROLLER(LaserSensor)
  void MainCalc() override;

  In<Eigen::Matrix<double, 1, 1>> raw_;
  Out<double> distance_;
  Eigen::Matrix<double, 1, 1> raw_value_ = Eigen::Matrix<double, 1, 1>::Zero();
};

}  // namespace dca::robot
