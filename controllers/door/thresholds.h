#pragma once
// The door's detectors: they end their run with DONE when a measured quantity reaches a level.
#include <dca/robot/signals.h>

namespace dca::door {

/// DistanceThreshold(host, distance=0.7, period=0.01): DONE(distance) when Distance <= `distance` (m).
///   in  Distance  scalar m (from LaserSensor)
class DistanceThreshold final : public PeriodicController {
  DCA_CONTROLLER(DistanceThreshold)
  void MainCalc() override;

  In<double> distance_;
  double level_;
};

/// ForceThreshold(host, force=6, samples=3, settle=0.3, period=0.01): DONE(|f - f0|) when the force differs
/// from the one measured at the start of the run (the tool's own weight) by more than `force` N for `samples`
/// ticks in a row. f0 is learnt (smoothed) during the first `settle` seconds, when nothing fires: the step
/// that starts a hit detector often starts with a jolt (the base stopping as the previous step ends).
///   in  Wrench  vector[6] N, N m (from ForceTorque)
class ForceThreshold final : public PeriodicController {
  DCA_CONTROLLER(ForceThreshold)
  void on_configure() override;
  void MainCalc() override;

  In<robot::Vec6> wrench_;
  double level_, settle_;
  std::int64_t need_, above_ = 0;
  bool have_bias_ = false;
  robot::Vec6 w_ = robot::Vec6::Zero();
  Eigen::Vector3d bias_ = Eigen::Vector3d::Zero();
};

}  // namespace dca::door
