#include "math/hinge_estimator.h"

#include <Eigen/LU>
#include <cmath>

namespace dca::math {

HingeEstimator::HingeEstimator(const Eigen::Vector2d& prior_centre, double prior_radius, double min_arc)
    : prior_centre_(prior_centre), prior_radius_(prior_radius), min_arc_(min_arc),
      centre_(prior_centre), radius_(prior_radius) {}

void HingeEstimator::Reset() {
  M_.setZero();
  b_.setZero();
  n_ = 0;
  centre_ = prior_centre_;
  radius_ = prior_radius_;
  fitted_ = false;
}

void HingeEstimator::Add(const Eigen::Vector2d& p) {
  const Eigen::Vector3d row(p.x(), p.y(), 1.0);
  const double z = p.squaredNorm();
  M_ += row * row.transpose();
  b_ -= row * z;
  if (n_ == 0) first_ = p;
  last_ = p;
  ++n_;
  Solve();
}

void HingeEstimator::Solve() {
  if (n_ < 3) return;
  const Eigen::Vector2d a = first_ - prior_centre_, b = last_ - prior_centre_;
  if (std::abs(std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b))) < min_arc_) return;
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(M_);
  if (!lu.isInvertible()) return;  // collinear samples: keep the last estimate
  const Eigen::Vector3d s = lu.solve(b_);
  const Eigen::Vector2d c(-s[0] / 2, -s[1] / 2);
  const double r2 = c.squaredNorm() - s[2];
  if (!(r2 > 0) || !std::isfinite(r2)) return;
  centre_ = c;
  radius_ = std::sqrt(r2);
  fitted_ = true;
}

double HingeEstimator::arc() const {
  if (n_ < 2) return 0;
  const Eigen::Vector2d a = first_ - centre_, b = last_ - centre_;
  return std::abs(std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b)));
}

Eigen::Vector2d HingeEstimator::Tangent(const Eigen::Vector2d& p, bool ccw) const {
  Eigen::Vector2d r = p - centre_;
  const double len = r.norm();
  if (len < 1e-9) return Eigen::Vector2d::Zero();
  r /= len;
  const Eigen::Vector2d t(-r.y(), r.x());  // +90 degrees: counter-clockwise
  return ccw ? t : -t;
}

}  // namespace dca::math
