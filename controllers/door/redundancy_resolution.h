#pragma once
// The drive of the whole robot: a tool twist spread over the base and the arm (paper, section 5).
#include "math/kinematics.h"
#include "math/redundancy.h"
#include <dca/robot/signals.h>

namespace dca::door {

using robot::Vec3;
using robot::Vec6;
using robot::Vec9;

/// RedundancyResolution(host, base_weight=10, arm_weight=1, damping=0.02, period=0.01, hold=0.01): distributes the
/// commanded tool twist over the base's 3 and the arm's 6 joints (weighted, damped least squares, joint-limit
/// avoidance in the null space), after applying the command's own base velocity.
///   in  In       vector[9] Vel (controllers/robot/signals.h), zero once `hold` s old (HeldCommand)
///   in  Joints   vector[6] arm joint angles
///   out BaseVel  vector[3] to XR4000Ctrl
///   out ArmVel   vector[6] to Puma560Ctrl
class RedundancyResolution final : public PeriodicController {
  DCA_CONTROLLER(RedundancyResolution)

 public:
  /// The maths of one tick: joint velocities (base 3, arm 6) for command `cmd` at arm angles `q`.
  static void Solve(const math::Chain& arm, const Vec9& cmd, const Vec6& q, const math::JointVector& weights,
                    const math::RedundancyParams& params, Vec3* base, Vec6* arm_qd);

 private:
  void on_configure() override { cmd_.reset(); }
  void MainCalc() override;

  In<Vec9> in_;
  In<Vec6> joints_;
  Out<Vec3> base_out_;
  Out<Vec6> arm_out_;
  math::Chain arm_;
  math::JointVector weights_;
  math::RedundancyParams params_;
  robot::HeldCommand<9> cmd_;
  Vec6 q_ = Vec6::Zero();
  bool have_q_ = false;
};

}  // namespace dca::door
