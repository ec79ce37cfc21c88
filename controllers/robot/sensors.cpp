#include "controllers/robot/sensors.h"

#include <dca/registry.h>

namespace dca::robot {

namespace {
const InSpec<Eigen::Matrix<double, 1, 1>> kRaw{.name = "Raw", .units = "m", .device = "laser.range"};
const OutSpec<double> kDistance{.name = "Distance", .units = "m"};
}  // namespace

Manifest LaserSensor::Describe() {
  return {.type = "LaserSensor", .doc = "the laser range finder: distance ahead of the base to the door's plane",
          .inputs = {kRaw}, .outputs = {kDistance}, .params = {PeriodParam()}, .ends = Ending::Never()};
}
LaserSensor::LaserSensor(const ControllerContext& ctx)
    : PeriodicController(ctx), raw_(port(kRaw)), distance_(port(kDistance)) {}
void LaserSensor::MainCalc() {
  if (raw_.read(raw_value_) == Read::New) distance_.write(raw_value_[0]);
}

DCA_REGISTER_CONTROLLER(XR4000Odometry);
DCA_REGISTER_CONTROLLER(Puma560Joints);
DCA_REGISTER_CONTROLLER(ForceTorque);
DCA_REGISTER_CONTROLLER(HandleCamera);
DCA_REGISTER_CONTROLLER(LaserSensor);

}  // namespace dca::robot
