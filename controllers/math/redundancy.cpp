#include "math/redundancy.h"

#include <Eigen/Cholesky>

namespace dca::math {

void Resolve(const JacobianMatrix& J, const Eigen::Matrix<double, 6, 1>& twist, const JointVector& weights,
             const JointVector& q, const JointVector& lower, const JointVector& upper,
             const RedundancyParams& params, JointVector* qdot) {
  const Eigen::Index n = J.cols();
  JointVector winv(n);
  for (Eigen::Index i = 0; i < n; ++i) winv[i] = 1.0 / weights[i];

  // J W^-1 (6 x n) and the 6x6 damped system.
  JacobianMatrix jw = J * winv.asDiagonal();
  Eigen::Matrix<double, 6, 6> A = jw * J.transpose();
  A.diagonal().array() += params.damping * params.damping;
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(A);

  // Primary task.
  *qdot = jw.transpose() * ldlt.solve(twist);

  // Joint-limit avoidance: inside the margin of a limit, a velocity back towards the range, weighted like
  // the task, then projected through the (damped) null space so that the twist is undisturbed.
  JointVector q0 = JointVector::Zero(n);
  bool any = false;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double range = upper[i] - lower[i];
    if (!(range > 0) || range > 1e6) continue;
    const double margin = params.limit_margin * range;
    if (q[i] < lower[i] + margin) {
      q0[i] = params.limit_gain * (lower[i] + margin - q[i]);
      any = true;
    } else if (q[i] > upper[i] - margin) {
      q0[i] = -params.limit_gain * (q[i] - (upper[i] - margin));
      any = true;
    }
  }
  if (any) {
    // (I - W^-1 J^T A^-1 J) q0 : the weighted null-space projection of q0.
    const Eigen::Matrix<double, 6, 1> jq0 = J * q0;
    *qdot += q0 - jw.transpose() * ldlt.solve(jq0);
  }
}

}  // namespace dca::math
