#include "controllers/door/linear_trajectory.h"

#include "controllers/registry.h"

namespace dca::door {

Manifest LinearTrajectory::Describe() {
  return {"LinearTrajectory", "moves the tool straight ahead; ABORTED after `distance` m",
          {}, {robot::VelPort()},
          {ParamSpec::Number("speed", "0.05", "m/s"), ParamSpec::Number("distance", "0.4", "m"),
           PeriodParam()},
          Ending::Aborted()};
}
LinearTrajectory::LinearTrajectory(const ControllerContext& ctx)
    : PeriodicController(ctx), vel_(actuator("Vel")), speed_(positive("speed")), distance_(positive("distance")) {
  v_[0] = speed_;
}
void LinearTrajectory::MainCalc() {
  if (to_seconds(now() - started()) * speed_ > distance_) {
    vel_.write(robot::Vec9::Zero().eval());
    return Abort("moved " + text("distance") + " m without reaching anything");
  }
  vel_.write(v_);
}

DCA_REGISTER_CONTROLLER(LinearTrajectory);

}  // namespace dca::door
