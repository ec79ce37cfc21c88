#include "door/compliant_ctrl.h"

#include <dca/registry.h>
#include "door/ports.h"
#include "robot/model.h"

namespace dca::door {

namespace {
const Param<double> kCompliance{.name = "compliance", .doc = "(m/s)/N", .def = 0.001};
const Param<double> kDeadband{.name = "deadband", .doc = "N", .def = 1};
const Param<double> kCompliantMaxSpeed{.name = "max_speed", .doc = "m/s", .def = 0.1, .above = 0};
}  // namespace

Manifest CompliantCtrl::Describe() {
  return {.type = "CompliantCtrl", .doc = "admittance: the tool gives way to the horizontal force it feels",
          .inputs = {kWrench, kJoints}, .outputs = {kVel},
          .params = {kCompliance, kDeadband, kCompliantMaxSpeed, PeriodParam()}, .ends = Ending::Never()};
}
CompliantCtrl::CompliantCtrl(const ControllerContext& ctx)
    : PeriodicController(ctx), wrench_(port(kWrench)), joints_(port(kJoints)), vel_(port(kVel)), arm_(robot::arm()),
      compliance_(param(kCompliance)), deadband_(param(kDeadband)), max_speed_(param(kCompliantMaxSpeed)) {}
void CompliantCtrl::on_configure() {
  have_q_ = have_w_ = false;
  v_.setZero();
}
void CompliantCtrl::MainCalc() {
  if (joints_.read(q_) == Read::New) have_q_ = true;
  if (wrench_.read(w_) == Read::New) have_w_ = true;
  v_.setZero();
  if (have_q_ && have_w_) {
    // The force in the base frame (tool0 and the sensor share their orientation); its horizontal part is free of
    // the tool's weight and is what the door and the handle push with.
    math::JointVector jq = q_;
    const Eigen::Vector3d f3 = arm_.Forward(jq).linear() * w_.head<3>();
    Eigen::Vector2d f(f3.x(), f3.y());
    const double n = f.norm();
    if (n > deadband_) {
      Eigen::Vector2d v = compliance_ * (n - deadband_) / n * f;
      if (v.norm() > max_speed_) v *= max_speed_ / v.norm();
      v_.head<2>() = v;
    }
  }
  vel_.write(v_);
}

DCA_REGISTER_CONTROLLER(CompliantCtrl);

}  // namespace dca::door
