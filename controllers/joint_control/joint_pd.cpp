#include "joint_pd.h"

#include <dca/registry.h>

namespace dca::joint_control {

namespace {
const InSpec<Eigen::VectorXd> kRef{.name = "Ref", .units = "rad or m"};
const InSpec<Eigen::VectorXd> kRefVel{.name = "RefVel", .units = "rad/s or m/s"};
const OutSpec<Eigen::VectorXd> kError{.name = "Error", .units = "rad or m"};
const Param<double> kKp{.name = "kp", .doc = "gain on the position error (N m/rad, or 1/s on velocity)", .min = 0};
const Param<double> kKd{.name = "kd", .doc = "gain on the velocity error (N m s/rad, or 1 on velocity)", .def = 0,
                        .min = 0};
const Param<std::string> kPdInterface{
    .name = "interface", .doc = "the command interface", .def = "effort", .allowed = {"effort", "velocity"}};
const Param<std::vector<double>> kTargets{.name = "targets",
                                          .doc = "the reference before any Ref: one per joint (none: hold)"};
}  // namespace

Manifest JointPD::Describe() {
  Manifest m{.type = "JointPD", .doc = "a joint-space PD for any arm's joints, to a reference (Ref) or targets",
             .params = {joints_param(), kKp, kKd, kPdInterface, PeriodParam(), kTargets},
             .ends = Ending::Aborted()};
  const Slots& s = slots(true);
  append(m.inputs, s.q);
  append(m.inputs, s.qd);
  m.inputs.push_back(kRef);
  m.inputs.push_back(kRefVel);
  append(m.outputs, s.cmd);
  m.outputs.push_back(kError);
  return m;
}

JointPD::JointPD(const ControllerContext& ctx)
    : JointGroup(ctx, slots(true)), ref_in_(port(kRef)), ref_vel_in_(port(kRefVel)), error_out_(port(kError)),
      kp_(param(kKp)), kd_(param(kKd)), velocity_(param(kPdInterface) == "velocity") {
  const std::vector<double> targets = param(kTargets);
  if (!targets.empty() && targets.size() != joints().size())
    throw bad_param("parameter 'targets': " + std::to_string(targets.size()) + " numbers for " +
                    std::to_string(size()) + " joints (one per joint, or none)");
  targets_ = Eigen::Map<const Eigen::VectorXd>(targets.data(), static_cast<Eigen::Index>(targets.size()));
  for (Eigen::VectorXd* v : {&ref_, &ref_vel_, &error_, &cmd_}) *v = Eigen::VectorXd::Zero(size());
}

void JointPD::on_configure() {
  reset_state();
  have_ref_ = targets_.size() > 0;
  if (have_ref_) ref_ = targets_;
  ref_vel_.setZero();
}

std::string JointPD::wrong_size(const char* input) const {
  return std::string("input ") + input + ": " + std::to_string(input_.size()) + " numbers for " +
         std::to_string(size()) + " joints";
}

void JointPD::MainCalc() {
  if (!read_state()) return;
  if (ref_in_.read(input_) == Read::New) {
    if (input_.size() != size()) return Abort(wrong_size("Ref"));
    ref_ = input_;
    have_ref_ = true;
  }
  if (ref_vel_in_.read(input_) == Read::New) {
    if (input_.size() != size()) return Abort(wrong_size("RefVel"));
    ref_vel_ = input_;
  }
  if (!have_ref_) {  // nothing to follow yet: hold the joints where they are
    ref_ = q_;
    have_ref_ = true;
  }
  error_ = ref_ - q_;
  cmd_ = kp_ * error_ + kd_ * (ref_vel_ - qd_);
  if (velocity_) cmd_ += ref_vel_;
  command(cmd_);
  error_out_.write(error_);
}

DCA_REGISTER_CONTROLLER(JointPD);

}  // namespace dca::joint_control
