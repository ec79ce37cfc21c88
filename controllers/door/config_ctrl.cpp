#include "controllers/door/config_ctrl.h"

#include "controllers/registry.h"
#include "controllers/robot/model.h"

namespace dca::door {

Manifest ConfigCtrl::Describe() {
  return {"ConfigCtrl", "moves the base under the tool to keep the arm in a comfortable configuration",
          {robot::JointsPort()}, {robot::VelPort()},
          {ParamSpec::Number("reach", "0.55", "the tool's preferred distance ahead of the shoulder axis, m"),
           ParamSpec::Number("gain", "1.5", "1/s"), ParamSpec::Number("max_speed", "0.2", "m/s"), PeriodParam()},
          Ending::Never()};
}
ConfigCtrl::ConfigCtrl(const ControllerContext& ctx)
    : PeriodicController(ctx), joints_(input("Joints")), vel_(actuator("Vel")), arm_(robot::arm()),
      reach_(positive("reach")), gain_(number("gain")), max_speed_(positive("max_speed")) {}
void ConfigCtrl::Init() {
  have_q_ = false;
  v_.setZero();
}
void ConfigCtrl::MainCalc() {
  if (fresh(joints_, q_)) have_q_ = true;
  v_.setZero();
  if (have_q_) {
    // The shoulder axis is joint 1's: its origin in the base frame is the chain's first joint origin.
    const Eigen::Vector3d shoulder = arm_.joints().front().origin.translation();
    const Eigen::Vector3d tool = robot::tool_position(arm_, q_);
    Eigen::Vector2d err(tool.x() - shoulder.x() - reach_, tool.y() - shoulder.y());
    Eigen::Vector2d b = gain_ * err;
    if (b.norm() > max_speed_) b *= max_speed_ / b.norm();
    v_[6] = b.x();
    v_[7] = b.y();
    v_[0] = -b.x();  // the tool stays where it is: the arm takes the base's motion back
    v_[1] = -b.y();
  }
  vel_.write(v_);
}

DCA_REGISTER_CONTROLLER(ConfigCtrl);

}  // namespace dca::door
