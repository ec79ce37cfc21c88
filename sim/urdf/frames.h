#pragma once
// The link frames of a URDF robot (docs/robots.md, "Link frames"): every link's frame in its parent link's frame
// (the root link's in "world"), the output links.frames of a URDF world and the foxglove.FrameTransforms of its
// viewers and recordings (host/codec/frames.h). C++17-clean: no Simbody types.
#include <string>
#include <vector>

#include "host/codec/frames.h"
#include "sim/urdf/description.h"

namespace dca::sim {

/// The link frames of `d` in port order: the root link in "world" first (none when the root link is itself
/// named "world"), then depth first from the root, each joint's child link in its parent link, the joints of a
/// link in urdfdom's order (by name).
std::vector<frames::Frame> link_frames(const RobotDescription& d);
/// The joint that places each frame's child (frames order; "" for the root's).
std::vector<std::string> frame_joints(const RobotDescription& d);

/// Forward kinematics from the URDF (the mock's link frames): each frame's child in its parent, 7 numbers per
/// frame into `out` (x y z qx qy qz qw): the joint's origin, then its motion by the joint's position `q[j]`
/// (d.joints order: about the axis for a revolute or continuous joint, along it for a prismatic one). Fixed,
/// floating and planar joints add no motion.
void joint_frames(const RobotDescription& d, const std::vector<double>& q, double* out);

}  // namespace dca::sim
