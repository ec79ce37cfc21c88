#pragma once
// Online estimate of a door's hinge position and radius from the path of the hand that holds its handle
// (the paper's ModelBasedCtrl, section 5): a circle fitted in the floor plane by linear least squares
// (Kasa's algebraic fit) over running sums. Until the hand has swept enough arc for the fit to mean anything,
// the estimate is the prior guess (the door's nominal geometry). Pure maths, no allocation, O(1) per sample.
#include <Eigen/Core>

namespace dca::math {

/// Estimates a circle (hinge centre, radius) from points on an arc.
class HingeEstimator {
 public:
  /// `prior_centre`/`prior_radius`: the guess before any motion (e.g. from the door's nominal geometry);
  /// `min_arc`: the arc (rad, measured about the prior centre) the samples must span before the fit is used.
  HingeEstimator(const Eigen::Vector2d& prior_centre, double prior_radius, double min_arc);

  /// Adds one hand position (floor plane, metres).
  void Add(const Eigen::Vector2d& p);
  /// Forgets every sample (the prior stays).
  void Reset();

  /// Number of samples added since the last Reset().
  long samples() const { return n_; }
  /// Angle (rad) swept by the samples around the current centre estimate: small arcs give poor estimates.
  double arc() const;
  /// True once the estimate comes from the samples rather than the prior.
  bool fitted() const { return fitted_; }
  /// The current estimate; with no usable data, the prior.
  const Eigen::Vector2d& centre() const { return centre_; }
  double radius() const { return radius_; }

  /// Unit tangent of the circle at point p, in the direction of increasing angle (counter-clockwise seen
  /// from above when `ccw` is true): the direction in which to move the hand to open the door.
  Eigen::Vector2d Tangent(const Eigen::Vector2d& p, bool ccw) const;

 private:
  void Solve();

  Eigen::Vector2d prior_centre_;
  double prior_radius_, min_arc_;
  // Normal equations of  x^2 + y^2 + D x + E y + F = 0  over the samples: M [D E F]^T = b.
  Eigen::Matrix3d M_ = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b_ = Eigen::Vector3d::Zero();
  long n_ = 0;
  Eigen::Vector2d first_ = Eigen::Vector2d::Zero(), last_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d centre_;
  double radius_;
  bool fitted_ = false;
};

}  // namespace dca::math
