#include "controllers/door/compliant_ctrl.h"

#include "controllers/registry.h"
#include "controllers/robot/model.h"

namespace dca::door {

Manifest CompliantCtrl::Describe() {
  using P = ParamSpec;
  return {"CompliantCtrl", "admittance: the tool gives way to the horizontal force it feels",
          {robot::WrenchPort(), robot::JointsPort()}, {robot::VelPort()},
          {P::Number("compliance", "0.001", "(m/s)/N"), P::Number("deadband", "1", "N"),
           P::Number("max_speed", "0.1", "m/s"), PeriodParam()},
          Ending::Never()};
}
CompliantCtrl::CompliantCtrl(const ControllerContext& ctx)
    : PeriodicController(ctx), wrench_(input("Wrench")), joints_(input("Joints")), vel_(actuator("Vel")),
      arm_(robot::arm()), compliance_(number("compliance")), deadband_(number("deadband")),
      max_speed_(positive("max_speed")) {}
void CompliantCtrl::Init() {
  have_q_ = have_w_ = false;
  v_.setZero();
}
void CompliantCtrl::MainCalc() {
  if (fresh(joints_, q_)) have_q_ = true;
  if (fresh(wrench_, w_)) have_w_ = true;
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
