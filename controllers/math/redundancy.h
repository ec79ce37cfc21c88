#pragma once
// Redundancy resolution: distributes a desired end-effector twist over the joints of a redundant system (a
// holonomic base's 3 and an arm's 6) by weighted, damped least squares, with joint-limit avoidance in the
// null space. Pure maths, no allocation (fixed maximum sizes), safe in MainCalc.
#include <Eigen/Core>

#include "math/kinematics.h"

namespace dca::math {

/// Parameters of Resolve().
struct RedundancyParams {
  /// Damping of the least-squares solution (twist units): keeps velocities bounded near singularities.
  double damping = 1e-3;
  /// Gain of the joint-limit avoidance term pushed through the null space (1/s).
  double limit_gain = 1.0;
  /// Fraction of each joint's range, at each end, in which limit avoidance acts (0..0.5).
  double limit_margin = 0.1;
};

/// Joint velocities qdot (size n = J.cols()) that realise `twist` with the least weighted effort:
///   qdot = W^-1 J^T (J W^-1 J^T + damping^2 I)^-1 twist + (I - J# J) qdot0
/// where W = diag(weights) (a larger weight makes a joint move less) and qdot0 drives joints that are inside
/// the margin of a limit (lower/upper, size n; use +-1e9 for none) back towards their range.
/// q (size n) are the current positions, used only for limit avoidance.
void Resolve(const JacobianMatrix& J, const Eigen::Matrix<double, 6, 1>& twist, const JointVector& weights,
             const JointVector& q, const JointVector& lower, const JointVector& upper,
             const RedundancyParams& params, JointVector* qdot);

}  // namespace dca::math
