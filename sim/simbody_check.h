#pragma once
// A C++17-clean window on the Simbody build this program links (no Simbody types here).
#include <string>

namespace dca::sim {

/// Builds a one-body pendulum in Simbody, realizes its topology and steps it `steps` times with
/// SemiExplicitEuler at `dt` seconds. Returns the pendulum angle (radians) reached from `q0`.
/// Guards the Debian/NDEBUG layout trap: a file compiled without -UNDEBUG crashes in realizeTopology().
double pendulum_angle_after(double q0, double dt, int steps);

/// "3.7" or whatever the linked SimTK says.
std::string simbody_version();

}  // namespace dca::sim
