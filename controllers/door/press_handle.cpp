#include "door/press_handle.h"

#include <dca/registry.h>
#include "door/ports.h"
#include "robot/model.h"

namespace dca::door {

namespace {
const Param<double> kPressSpeed{.name = "speed", .doc = "downward speed of the tool, m/s", .def = 0.03, .above = 0};
const Param<double> kPressForce{.name = "force", .doc = "the force (N) at which the handle counts as stopped",
                                .def = 30, .above = 0};
const Param<double> kTravel{.name = "travel", .doc = "the travel (m) the handle must allow before it stops",
                            .def = 0.02, .above = 0};
const Param<double> kPressCompliance{.name = "compliance", .doc = "horizontal admittance, (m/s)/N", .def = 0.002};
}  // namespace

Manifest PressHandle::Describe() {
  return {.type = "PressHandle", .doc = "presses the grasped handle down, compliantly, until it stops",
          .inputs = {kWrench, kJoints}, .outputs = {kVel},
          .params = {kPressSpeed, kPressForce, kTravel, kPressCompliance, PeriodParam()},
          .ends = Ending::DoneOrAborted()};
}
PressHandle::PressHandle(const ControllerContext& ctx)
    : PeriodicController(ctx), wrench_(port(kWrench)), joints_(port(kJoints)), vel_(port(kVel)), arm_(robot::arm()),
      speed_(param(kPressSpeed)), force_(param(kPressForce)), travel_(param(kTravel)),
      compliance_(param(kPressCompliance)) {}
void PressHandle::on_configure() {
  have_start_ = have_bias_ = false;
  v_.setZero();
}
void PressHandle::MainCalc() {
  const bool new_q = joints_.read(q_) == Read::New;
  const bool new_w = wrench_.read(w_) == Read::New;
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
    return Abort("handle jammed: " + text(kPressForce) + " N reached after " + std::to_string(travel) +
                 " m of travel (needs " + text(kTravel) + " m)");
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
