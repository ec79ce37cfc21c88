#pragma once
// The door pushed open along its estimated circle (paper, section 5: the model-based controller).
#include <optional>

#include "math/hinge_estimator.h"
#include "math/kinematics.h"
#include <dca/robot/signals.h>

namespace dca::door {

/// ModelBasedCtrl(host, speed=0.15, angle=75, radius=0.75, side="right", min_arc=0.1, period=0.01): estimates
/// the hinge and the door's radius online from the hand's path (HingeEstimator) and moves the hand along the
/// circle, pushing the door open. Until the hand has swept `min_arc` rad, or while the fitted radius is not
/// within [0.5, 2] x `radius`, the circle is the guess: a hinge `radius` m to the `side` of the hand in the door's
/// plane (across the robot's heading at the start). DONE(angle in degrees) when the opening measured on the
/// fitted circle reaches `angle` degrees.
///   in  BasePose  vector[3] m, m, rad (from XR4000Odometry)
///   in  Joints    vector[6] rad
///   out Vel       vector[9] Vel
class ModelBasedCtrl final : public PeriodicController {
  DCA_CONTROLLER(ModelBasedCtrl)

 public:
  /// Whether a fit is to be trusted: fitted, with a radius within [0.5, 2] x the guess.
  static bool Plausible(const math::HingeEstimator& e, double prior_radius);

 private:
  void on_configure() override;
  void MainCalc() override;

  In<robot::Vec3> pose_;
  In<robot::Vec6> joints_;
  Out<robot::Vec9> vel_;
  math::Chain arm_;
  double speed_, target_, radius_, min_arc_, side_;
  robot::Vec3 base_ = robot::Vec3::Zero();
  robot::Vec6 q_ = robot::Vec6::Zero();
  bool have_pose_ = false, have_q_ = false, started_ = false;
  std::optional<math::HingeEstimator> est_;
  Eigen::Vector2d start_ = Eigen::Vector2d::Zero(), push_ = Eigen::Vector2d::Zero(),
                  prior_centre_ = Eigen::Vector2d::Zero();
  robot::Vec9 v_ = robot::Vec9::Zero();
};

}  // namespace dca::door
