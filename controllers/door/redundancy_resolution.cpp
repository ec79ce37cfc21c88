#include "controllers/door/redundancy_resolution.h"

#include "controllers/registry.h"
#include "controllers/robot/model.h"

namespace dca::door {

Manifest RedundancyResolution::Describe() {
  return {"RedundancyResolution",
          "spreads a tool twist over the base (3) and the arm (6): weighted, damped least squares",
          {robot::VelPort("In"), robot::JointsPort()},
          {vector_port("BaseVel", 3, "m/s, m/s, rad/s"), vector_port("ArmVel", 6, "rad/s")},
          {ParamSpec::Number("base_weight", "10", "cost of base motion (higher: the arm does more)"),
           ParamSpec::Number("arm_weight", "1", "cost of arm motion"),
           ParamSpec::Number("damping", "0.02", "least-squares damping near singularities"),
           PeriodParam(), robot::HoldParam()},
          Ending::Never()};
}
RedundancyResolution::RedundancyResolution(const ControllerContext& ctx)
    : PeriodicController(ctx), in_(input("In")), joints_(input("Joints")), base_out_(actuator("BaseVel")),
      arm_out_(actuator("ArmVel")), arm_(robot::arm()), cmd_(positive("hold")) {
  weights_.resize(9);
  weights_.head<3>().setConstant(positive("base_weight"));
  weights_.tail<6>().setConstant(positive("arm_weight"));
  params_.damping = number("damping");
}

void RedundancyResolution::Solve(const math::Chain& arm, const Vec9& cmd, const Vec6& q,
                                 const math::JointVector& weights, const math::RedundancyParams& params,
                                 Vec3* base, Vec6* arm_qd) {
  math::JointVector jq = q;
  math::JacobianMatrix J;
  math::MobileJacobian(math::BasePose{}, arm, jq, &J);
  math::JointVector qall(9), lo(9), hi(9), qd(9);
  qall.head<3>().setZero();
  qall.tail<6>() = q;
  lo.head<3>().setConstant(-1e9);
  hi.head<3>().setConstant(1e9);
  for (int i = 0; i < 6; ++i) {
    lo[3 + i] = arm.lower(i);
    hi[3 + i] = arm.upper(i);
  }
  const Vec6 twist = cmd.head<6>();
  math::Resolve(J, twist, weights, qall, lo, hi, params, &qd);
  *base = cmd.tail<3>() + qd.head<3>();
  *arm_qd = qd.tail<6>();
}

void RedundancyResolution::MainCalc() {
  if (fresh(joints_, q_)) have_q_ = true;
  const Vec9& cmd = cmd_.update(in_, now());
  Vec3 base = Vec3::Zero();
  Vec6 arm = Vec6::Zero();
  if (have_q_ && !cmd.isZero()) Solve(arm_, cmd, q_, weights_, params_, &base, &arm);
  base_out_.write(base);
  arm_out_.write(arm);
}

DCA_REGISTER_CONTROLLER(RedundancyResolution);

}  // namespace dca::door
