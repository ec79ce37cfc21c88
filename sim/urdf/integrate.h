#pragma once
// One step of semi-explicit Euler on a Simbody system, as the door world steps (sim/world.h): u1 = u0 + h udot(t0),
// q1 = q0 + h N(q0) u1. Shared by the URDF world and its bare baseline (sim/urdf/bare.h) so that the benchmark
// compares the same integration. Includes Simbody: sim/*.cpp only.
#include <Simbody.h>

namespace dca::sim {

/// Advances `s` by `h`, realized to Velocity afterwards (the forces are evaluated at the step's start).
inline void euler_step(const SimTK::MultibodySystem& system, const SimTK::SimbodyMatterSubsystem& matter,
                       SimTK::State& s, double h, SimTK::Vector& qdot) {
  system.realize(s, SimTK::Stage::Acceleration);
  s.updU() += h * s.getUDot();
  matter.multiplyByN(s, false, s.getU(), qdot);
  s.updQ() += h * qdot;
  s.updTime() += h;
  system.realize(s, SimTK::Stage::Velocity);
}

}  // namespace dca::sim
