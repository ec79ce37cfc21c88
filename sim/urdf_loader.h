#pragma once
// URDF -> Simbody. This header includes Simbody: only sim/*.cpp (C++17, -UNDEBUG) may include it.
// Mapping: revolute/continuous -> Pin, prismatic -> Slider, fixed -> Weld, planar -> Planar, floating -> Free.
// A Pin turns about its Z axis and a Slider moves along X, so each mobilizer's frames carry the rotation that
// takes Z (Pin, Planar) or X (Slider) onto the URDF axis: the minimal rotation, and a half turn about X when
// the axis is -Z (-X for a Slider: about Z). The Planar's coordinates are (angle, x, y) in that frame.
// A massless link on a fixed joint is no body: it becomes a frame on its parent's body.
// Limits become Force::MobilityLinearStop, dynamics damping Force::MobilityLinearDamper.
#include <Simbody.h>

#include <map>
#include <string>
#include <vector>

#include "sim/urdf_parse.h"

namespace dca::sim {

/// Tuning of the forces the loader adds.
struct LoaderOptions {
  double period = 1e-3;              ///< the integration step: stop stiffness is limited for stability
  double stop_stiffness = 2e4;       ///< N m/rad (or N/m): joint-limit stiffness, at most what `period` allows
  double stop_dissipation = 0.1;     ///< s/rad (or s/m): Hunt-Crossley dissipation of the stops
};

/// One URDF joint that moves.
struct LoadedJoint {
  std::string name;
  int type = 0;                      ///< urdf::Joint type
  SimTK::MobilizedBodyIndex body;    ///< the body this joint's mobilizer moves
  int nq = 0, nu = 0;                ///< its coordinates (Pin/Slider 1, Planar 3, Free 7 and 6)
};

/// Where a URDF's links and joints went in the Simbody system.
struct LoadedUrdf {
  std::string file;
  std::map<std::string, SimTK::MobilizedBodyIndex> link_body;   ///< every link -> the body carrying it
  std::map<std::string, SimTK::Transform> link_in_body;         ///< X_BL: the link frame on that body
  std::map<std::string, SimTK::MobilizedBodyIndex> weld_body;   ///< fixed joint -> welded child body
  std::vector<LoadedJoint> joints;                              ///< moving joints, parents first
  const LoadedJoint* joint(const std::string& name) const;      ///< nullptr if unknown
  /// The link's frame in Ground (state realized to Position).
  SimTK::Transform link_pose(const SimTK::SimbodyMatterSubsystem& matter, const SimTK::State& s,
                             const std::string& link) const;
};

/// Adds `urdf`'s links as bodies of `matter`, its root link welded to `parent` at `X_parent_root`.
/// Throws UrdfError naming the file and the joint when Simbody rejects something.
LoadedUrdf add_urdf(SimTK::SimbodyMatterSubsystem& matter, SimTK::GeneralForceSubsystem& forces,
                    const ParsedUrdf& urdf, SimTK::MobilizedBody& parent,
                    const SimTK::Transform& X_parent_root, const LoaderOptions& options = {});

}  // namespace dca::sim
