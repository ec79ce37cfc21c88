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

#include "controllers/robot/signals.h"

namespace dca::robot {

/// What tells one pass-through sensor from another: its manifest.
struct SensorSpec {
  std::string_view type, doc;
  std::string_view input, output, units, signal;  ///< the device input, the output, both ports' units
};

/// A pass-through sensor: copies each fresh vector[N] sample of its device input to its output.
template <int N, const SensorSpec& S>
class Sensor final : public PeriodicController {
 public:
  static Manifest Describe() {
    return {std::string(S.type), std::string(S.doc),
            {device(vector_port(std::string(S.input), N, std::string(S.units)), std::string(S.signal))},
            {vector_port(std::string(S.output), N, std::string(S.units))},
            {PeriodParam()},
            Ending::Never()};
  }
  explicit Sensor(const ControllerContext& ctx)
      : PeriodicController(ctx), in_(input(S.input)), out_(output(S.output)) {}

 private:
  void MainCalc() override {
    if (fresh(in_, v_)) out_.write(v_);
  }

  Input& in_;
  Output& out_;
  Eigen::Matrix<double, N, 1> v_ = Eigen::Matrix<double, N, 1>::Zero();
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

  Input& raw_;
  Output& distance_;
};

}  // namespace dca::robot
