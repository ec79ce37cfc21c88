#include "controllers/robot/joints.h"

#include <cmath>

#include "controllers/registry.h"

namespace dca::robot {

Manifest JointSetpoint::Describe() {
  return {"JointSetpoint", "drives one joint of a URDF world to a target; DONE(position) when there",
          {device(vector_port("Q", 1, "rad or m"), "joint.{joint}.position"),
           device(vector_port("Qd", 1, "rad/s or m/s"), "joint.{joint}.velocity")},
          {device(vector_port("Cmd", 1, "rad or m, or rad/s or m/s"), "joint.{joint}.{interface}_command")},
          {ParamSpec::Required("joint", "string", "the joint's name in the URDF"),
           ParamSpec::Required("target", "number", "the position to reach (rad or m)"),
           ParamSpec::Number("tolerance", "0.01", "DONE within this of the target, and slower than it per second"),
           ParamSpec::Optional("interface", "string", "position", "the command interface: position or velocity"),
           ParamSpec::Number("gain", "2", "velocity interface: the command is gain * error (1/s)"),
           ParamSpec::Number("timeout", "30", "ABORTED when not there after this many seconds"),
           PeriodParam()},
          Ending::DoneOrAborted()};
}

JointSetpoint::JointSetpoint(const ControllerContext& ctx)
    : PeriodicController(ctx), q_in_(input("Q")), qd_in_(input("Qd")), cmd_(output("Cmd")),
      target_(number("target")), tolerance_(positive("tolerance")), gain_(positive("gain")),
      timeout_(positive("timeout")) {
  const std::string i = text("interface");
  if (i != "position" && i != "velocity") throw bad_param("interface must be \"position\" or \"velocity\", got \"" + i + "\"");
  velocity_ = i == "velocity";
}

void JointSetpoint::Init() {
  have_q_ = false;
  near_ = 0;
  qd_.setZero();
}

void JointSetpoint::MainCalc() {
  if (fresh(q_in_, q_)) have_q_ = true;
  fresh(qd_in_, qd_);
  if (!have_q_) return;
  const double error = target_ - q_[0];
  cmd_value_[0] = velocity_ ? gain_ * error : target_;
  cmd_.write(cmd_value_);
  near_ = std::abs(error) <= tolerance_ && std::abs(qd_[0]) <= tolerance_ ? near_ + 1 : 0;
  if (near_ >= 2) return Done(q_[0]);
  if (to_seconds(now() - started()) > timeout_)
    Abort("joint " + text("joint") + " did not reach " + text("target") + " within " + text("timeout") + " s");
}

void JointSetpoint::Stop() {
  if (velocity_) {
    cmd_value_.setZero();
    cmd_.write(cmd_value_);
  }
  PeriodicController::Stop();
}

DCA_REGISTER_CONTROLLER(JointSetpoint);

}  // namespace dca::robot
