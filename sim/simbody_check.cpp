#include "sim/simbody_check.h"

#include <Simbody.h>

namespace dca::sim {

double pendulum_angle_after(double q0, double dt, int steps) {
  SimTK::MultibodySystem system;
  SimTK::SimbodyMatterSubsystem matter(system);
  SimTK::GeneralForceSubsystem forces(system);
  SimTK::Force::UniformGravity gravity(forces, matter, SimTK::Vec3(0, -9.81, 0));
  SimTK::Body::Rigid body(SimTK::MassProperties(1.0, SimTK::Vec3(0), SimTK::UnitInertia(1)));
  SimTK::MobilizedBody::Pin pendulum(matter.Ground(), SimTK::Transform(SimTK::Vec3(0)), body,
                                     SimTK::Transform(SimTK::Vec3(0, 1, 0)));
  SimTK::State state = system.realizeTopology();
  pendulum.setOneQ(state, 0, q0);
  SimTK::SemiExplicitEulerIntegrator integrator(system, dt);
  integrator.initialize(state);
  for (int i = 1; i <= steps; ++i) integrator.stepTo(i * dt);
  return pendulum.getOneQ(integrator.getState(), 0);
}

std::string simbody_version() {
  int major = 0, minor = 0, build = 0;
  SimTK_version_SimTKcommon(&major, &minor, &build);
  return std::to_string(major) + "." + std::to_string(minor);
}

}  // namespace dca::sim
