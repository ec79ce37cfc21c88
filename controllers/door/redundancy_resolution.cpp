#include "door/redundancy_resolution.h"

#include <dca/registry.h>
#include "door/ports.h"
#include "robot/model.h"

namespace dca::door {

namespace {
const InSpec<Vec9> kIn = robot::VelIn("In");
const OutSpec<Vec3> kBaseVel{.name = "BaseVel", .units = "m/s, m/s, rad/s", .actuator = true};
const OutSpec<Vec6> kArmVel{.name = "ArmVel", .units = "rad/s", .actuator = true};
const Param<double> kBaseWeight{.name = "base_weight", .doc = "cost of base motion (higher: the arm does more)",
                                .def = 10, .above = 0};
const Param<double> kArmWeight{.name = "arm_weight", .doc = "cost of arm motion", .def = 1, .above = 0};
const Param<double> kDamping{.name = "damping", .doc = "least-squares damping near singularities", .def = 0.02};
}  // namespace

Manifest RedundancyResolution::Describe() {
  return {.type = "RedundancyResolution",
          .doc = "spreads a tool twist over the base (3) and the arm (6): weighted, damped least squares",
          .inputs = {kIn, kJoints}, .outputs = {kBaseVel, kArmVel},
          .params = {kBaseWeight, kArmWeight, kDamping, PeriodParam(), robot::HoldParam()}, .ends = Ending::Never()};
}
RedundancyResolution::RedundancyResolution(const ControllerContext& ctx)
    : PeriodicController(ctx), in_(port(kIn)), joints_(port(kJoints)), base_out_(port(kBaseVel)),
      arm_out_(port(kArmVel)), arm_(robot::arm()), cmd_(param(robot::HoldParam())) {
  weights_.resize(9);
  weights_.head<3>().setConstant(param(kBaseWeight));
  weights_.tail<6>().setConstant(param(kArmWeight));
  params_.damping = param(kDamping);
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
  if (joints_.read(q_) == Read::New) have_q_ = true;
  const Vec9& cmd = cmd_.update(in_, now());
  Vec3 base = Vec3::Zero();
  Vec6 arm = Vec6::Zero();
  if (have_q_ && !cmd.isZero()) Solve(arm_, cmd, q_, weights_, params_, &base, &arm);
  base_out_.write(base);
  arm_out_.write(arm);
}

DCA_REGISTER_CONTROLLER(RedundancyResolution);

}  // namespace dca::door
