#include "door/linear_trajectory.h"

#include <dca/registry.h>
#include "door/ports.h"

namespace dca::door {

namespace {
const Param<double> kLinearSpeed{.name = "speed", .doc = "m/s", .def = 0.05, .above = 0};
const Param<double> kLinearDistance{.name = "distance", .doc = "m", .def = 0.4, .above = 0};
}  // namespace

Manifest LinearTrajectory::Describe() {
  return {.type = "LinearTrajectory", .doc = "moves the tool straight ahead; ABORTED after `distance` m",
          .outputs = {kVel}, .params = {kLinearSpeed, kLinearDistance, PeriodParam()}, .ends = Ending::Aborted()};
}
LinearTrajectory::LinearTrajectory(const ControllerContext& ctx)
    : PeriodicController(ctx), vel_(port(kVel)), speed_(param(kLinearSpeed)), distance_(param(kLinearDistance)) {
  v_[0] = speed_;
}
void LinearTrajectory::MainCalc() {
  if (to_seconds(now() - started()) * speed_ > distance_) {
    vel_.write(robot::Vec9::Zero().eval());
    return Abort("moved " + text(kLinearDistance) + " m without reaching anything");
  }
  vel_.write(v_);
}

DCA_REGISTER_CONTROLLER(LinearTrajectory);

}  // namespace dca::door
