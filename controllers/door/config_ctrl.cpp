#include "door/config_ctrl.h"

#include <dca/registry.h>
#include "door/ports.h"
#include "robot/model.h"

namespace dca::door {

namespace {
const Param<double> kReach{.name = "reach", .doc = "the tool's preferred distance ahead of the shoulder axis, m",
                           .def = 0.55, .above = 0};
const Param<double> kConfigGain{.name = "gain", .doc = "1/s", .def = 1.5};
const Param<double> kConfigMaxSpeed{.name = "max_speed", .doc = "m/s", .def = 0.2, .above = 0};
}  // namespace

Manifest ConfigCtrl::Describe() {
  return {.type = "ConfigCtrl", .doc = "moves the base under the tool to keep the arm in a comfortable configuration",
          .inputs = {kJoints}, .outputs = {kVel}, .params = {kReach, kConfigGain, kConfigMaxSpeed, PeriodParam()},
          .ends = Ending::Never()};
}
ConfigCtrl::ConfigCtrl(const ControllerContext& ctx)
    : PeriodicController(ctx), joints_(port(kJoints)), vel_(port(kVel)), arm_(robot::arm()), reach_(param(kReach)),
      gain_(param(kConfigGain)), max_speed_(param(kConfigMaxSpeed)) {}
void ConfigCtrl::on_configure() {
  have_q_ = false;
  v_.setZero();
}
void ConfigCtrl::MainCalc() {
  if (joints_.read(q_) == Read::New) have_q_ = true;
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
