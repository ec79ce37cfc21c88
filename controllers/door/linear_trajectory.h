#pragma once
// The door's search for the handle: a straight move of the tool.
#include <dca/robot/signals.h>

namespace dca::door {

/// LinearTrajectory(host, speed=0.05, distance=0.4, period=0.01): moves the tool straight ahead (base x) at
/// `speed` m/s; ABORTED after `distance` m (nothing was hit).
///   out Vel  vector[9] Vel
class LinearTrajectory final : public PeriodicController {
  DCA_CONTROLLER(LinearTrajectory)
  void MainCalc() override;

  Out<robot::Vec9> vel_;
  double speed_, distance_;
  robot::Vec9 v_ = robot::Vec9::Zero();
};

}  // namespace dca::door
