#pragma once
// The door's handle: pressed down, compliantly.
#include "math/kinematics.h"
#include <dca/robot/signals.h>

namespace dca::door {

/// PressHandle(host, speed=0.03, force=30, travel=0.02, compliance=0.002, period=0.01): presses the grasped
/// handle down (the tool moves down at `speed`; a horizontal admittance lets it follow the lever's arc) until
/// the vertical force (beyond the one at the start: the tool's weight) reaches `force` N. DONE(travel) when the
/// tool had moved at least `travel` m down by then; ABORTED "handle jammed: <force> N reached ..." otherwise.
///   in  Wrench  vector[6] N, N m (from ForceTorque)
///   in  Joints  vector[6] rad
///   out Vel     vector[9] Vel
class PressHandle final : public PeriodicController {
  DCA_CONTROLLER(PressHandle)
  void on_configure() override;
  void MainCalc() override;

  In<robot::Vec6> wrench_, joints_;
  Out<robot::Vec9> vel_;
  math::Chain arm_;
  double speed_, force_, travel_, compliance_, z0_ = 0;
  robot::Vec6 w_ = robot::Vec6::Zero(), q_ = robot::Vec6::Zero();
  bool have_start_ = false, have_bias_ = false;
  Eigen::Vector3d bias_ = Eigen::Vector3d::Zero();
  robot::Vec9 v_ = robot::Vec9::Zero();
};

}  // namespace dca::door
