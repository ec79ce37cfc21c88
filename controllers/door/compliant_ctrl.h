#pragma once
// The door's closed chain kept free of large internal forces: an admittance.
#include "math/kinematics.h"
#include <dca/robot/signals.h>

namespace dca::door {

/// CompliantCtrl(host, compliance=0.001, deadband=1, max_speed=0.1, period=0.01): an admittance in the floor
/// plane: the tool moves along the horizontal force it feels (in the base frame, where the tool's weight has no
/// horizontal part; beyond `deadband` N, at most `max_speed`), so the closed chain through the door stays free of
/// large internal forces. Vertically it holds still (the handle stays pressed).
///   in  Wrench  vector[6] N, N m (from ForceTorque)
///   in  Joints  vector[6] rad
///   out Vel     vector[9] Vel
class CompliantCtrl final : public PeriodicController {
  DCA_CONTROLLER(CompliantCtrl)
  void on_configure() override;
  void MainCalc() override;

  In<robot::Vec6> wrench_, joints_;
  Out<robot::Vec9> vel_;
  math::Chain arm_;
  double compliance_, deadband_, max_speed_;
  robot::Vec6 w_ = robot::Vec6::Zero(), q_ = robot::Vec6::Zero();
  bool have_q_ = false, have_w_ = false;
  robot::Vec9 v_ = robot::Vec9::Zero();
};

}  // namespace dca::door
