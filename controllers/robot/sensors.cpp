#include "controllers/robot/sensors.h"

#include "controllers/registry.h"

namespace dca::robot {

Manifest LaserSensor::Describe() {
  return {"LaserSensor", "the laser range finder: distance ahead of the base to the door's plane",
          {device(vector_port("Raw", 1, "m"), "laser.range")},
          {scalar_port("Distance", "m")},
          {PeriodParam()},
          Ending::Never()};
}
LaserSensor::LaserSensor(const ControllerContext& ctx)
    : PeriodicController(ctx), raw_(input("Raw")), distance_(output("Distance")) {}
void LaserSensor::MainCalc() {
  if (raw_.take_latest() && raw_.vector().size() == 1) distance_.write(raw_.vector()[0]);
}

DCA_REGISTER_CONTROLLER(XR4000Odometry);
DCA_REGISTER_CONTROLLER(Puma560Joints);
DCA_REGISTER_CONTROLLER(ForceTorque);
DCA_REGISTER_CONTROLLER(HandleCamera);
DCA_REGISTER_CONTROLLER(LaserSensor);

}  // namespace dca::robot
