#pragma once
// The robot's drives: the Nomad XR4000 base and the Puma 560 arm (see dca/robot/signals.h for `hold`).
// Each tick writes the held command to the device; halt() writes zero (the command is an actuator).
#include <dca/robot/signals.h>

namespace dca::robot {

/// A velocity drive: each tick, its command (input Vel, zero once `hold` s old) goes to the device output Cmd.
template <int N>
class Drive : public PeriodicController {
 public:
  using Vec = Eigen::Matrix<double, N, 1>;

 protected:
  Drive(const ControllerContext& ctx, const InSpec<Vec>& vel, const OutSpec<Vec>& cmd)
      : PeriodicController(ctx), vel_(port(vel)), cmd_(port(cmd)), v_(param(HoldParam())) {}
  void MainCalc() override { cmd_.write(v_.update(vel_, now())); }

 private:
  void on_configure() override { v_.reset(); }

  In<Vec> vel_;
  Out<Vec> cmd_;
  HeldCommand<N> v_;
};

/// XR4000Ctrl(host, period=0.01, hold=0.01): the base's velocity drive.
///   in  Vel     vector[3] base velocity command (m/s, m/s, rad/s), zero once `hold` s old (HeldCommand)
///   out Cmd     vector[3] device base.cmd_vel
class XR4000Ctrl final : public Drive<3> {
  DCA_CONTROLLER(XR4000Ctrl)
};

/// Puma560Ctrl(host, period=0.01, hold=0.01): the arm's joint-velocity drive, which also publishes the joint
/// angles.
///   in  Vel     vector[6] joint velocity command (rad/s), zero once `hold` s old (HeldCommand)
///   in  Q       vector[6] device arm.q
///   out Cmd     vector[6] device arm.cmd_qd
///   out Joints  vector[6] joint angles (rad)
class Puma560Ctrl final : public Drive<6> {
  DCA_CONTROLLER(Puma560Ctrl)
  void MainCalc() override;

  In<Vec6> q_in_;
  Out<Vec6> joints_;
  Vec6 q_ = Vec6::Zero();
};

}  // namespace dca::robot
