#pragma once
// The arm kept in a comfortable configuration while the door opens.
#include "math/kinematics.h"
#include <dca/robot/signals.h>

namespace dca::door {

/// ConfigCtrl(host, reach=0.55, gain=1.5, max_speed=0.2, period=0.01): keeps the arm away from singular,
/// stretched or folded configurations by moving the base under the still tool so that the tool stays `reach` m
/// ahead of the shoulder axis and straight in front of it.
///   in  Joints  vector[6] rad
///   out Vel     vector[9] Vel
class ConfigCtrl final : public PeriodicController {
  DCA_CONTROLLER(ConfigCtrl)
  void on_configure() override;
  void MainCalc() override;

  In<robot::Vec6> joints_;
  Out<robot::Vec9> vel_;
  math::Chain arm_;
  double reach_, gain_, max_speed_;
  robot::Vec6 q_ = robot::Vec6::Zero();
  bool have_q_ = false;
  robot::Vec9 v_ = robot::Vec9::Zero();
};

}  // namespace dca::door
