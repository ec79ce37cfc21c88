#include "controllers/door/press_handle.h"

#include "controllers/registry.h"
#include "controllers/robot/model.h"

namespace dca::door {

Manifest PressHandle::Describe() {
  using P = ParamSpec;
  return {"PressHandle", "presses the grasped handle down, compliantly, until it stops",
          {robot::WrenchPort(), robot::JointsPort()}, {robot::VelPort()},
          {P::Number("speed", "0.03", "downward speed of the tool, m/s"),
           P::Number("force", "30", "the force (N) at which the handle counts as stopped"),
           P::Number("travel", "0.02", "the travel (m) the handle must allow before it stops"),
           P::Number("compliance", "0.002", "horizontal admittance, (m/s)/N"), PeriodParam()},
          Ending::DoneOrAborted()};
}
PressHandle::PressHandle(const ControllerContext& ctx)
    : PeriodicController(ctx), wrench_(input("Wrench")), joints_(input("Joints")), vel_(actuator("Vel")),
      arm_(robot::arm()), speed_(positive("speed")), force_(positive("force")), travel_(positive("travel")),
      compliance_(number("compliance")) {}
void PressHandle::Init() {
  have_start_ = have_bias_ = false;
  v_.setZero();
}
void PressHandle::MainCalc() {
  const bool new_q = fresh(joints_, q_);
  const bool new_w = fresh(wrench_, w_);
  if (!have_start_) {
    if (!new_q) return;
    z0_ = robot::tool_position(arm_, q_).z();
    have_start_ = true;
  }
  math::JointVector jq = q_;
  const Eigen::Isometry3d tool = arm_.Forward(jq);
  // The wrench in the base frame (tool0 and the sensor share their orientation).
  const Eigen::Vector3d f = tool.linear() * w_.head<3>();
  if (!have_bias_) {
    if (!new_w) return;
    bias_ = f;  // vertically: the tool's weight and whatever the grasp holds
    have_bias_ = true;
  }
  const double travel = z0_ - tool.translation().z();
  // The handle pushes the tool up as it is pressed: the tool feels +z from the lever.
  if (f.z() - bias_.z() >= force_) {
    vel_.write(robot::Vec9::Zero().eval());
    if (travel >= travel_) return Done(travel);
    return Abort("handle jammed: " + text("force") + " N reached after " + std::to_string(travel) +
                 " m of travel (needs " + text("travel") + " m)");
  }
  // Down at `speed`; horizontally the tool gives way to the lever (which swings in the door's plane), and to
  // any push left from the approach.
  v_.setZero();
  v_[0] = compliance_ * f.x();
  v_[1] = compliance_ * f.y();
  v_[2] = -speed_;
  vel_.write(v_);
}

DCA_REGISTER_CONTROLLER(PressHandle);

}  // namespace dca::door
