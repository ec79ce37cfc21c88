#pragma once
// The door: its dimensions and the URDF generated from them (worlds/door/models/door.urdf is the nominal one).
// C++17-clean. Frames (see worlds/door/models/README.md): the door frame has its origin on the hinge axis at the floor,
// x along the door's normal pointing away from the side the robot approaches from (the push direction), y
// along the closed leaf from the hinge towards the handle, z up. The approach face of the closed leaf is the
// plane x = 0.
#include <string>

namespace dca::sim {

/// Everything that defines a door. Angles in radians, lengths in metres, masses in kg.
struct DoorParams {
  double width = 0.9;              ///< leaf width (0.8-1.0 in the scenarios)
  double height = 2.0;             ///< leaf height
  double thickness = 0.04;         ///< leaf thickness
  double mass_per_m2 = 14.0;       ///< leaf areal mass (0.9 x 2.0 m -> 25.2 kg)
  double hinge_damping = 3.0;      ///< N m s/rad on the hinge
  double max_angle = 1.75;         ///< the hinge's stop (100 degrees open)
  double handle_height = 1.0;      ///< the handle's pivot above the floor
  double handle_backset = 0.07;    ///< the pivot's distance from the leaf's free edge
  double handle_standoff = 0.065;  ///< the lever bar's axis in front of the approach face
  double lever_length = 0.13;      ///< from the pivot axis to the lever's tip, towards the hinge
  double lever_radius = 0.01;      ///< the lever bar's radius
  double grasp_offset = 0.075;     ///< the feature/grasp point on the bar, from the pivot axis
  double handle_mass = 0.3;
  double handle_max = 0.7;         ///< the handle's stop when pressed (40 degrees)
  double handle_damping = 0.05;    ///< N m s/rad
  double handle_spring = 1.0;      ///< N m/rad return spring
  double handle_preload = 0.4;     ///< N m: the spring's torque at rest against the upper stop
  double latch_release = 0.45;     ///< handle angle past which the latch lets the door open (26 degrees)
  double latch_play = 0.005;       ///< how far the latched door can move (rad)
  double latch_stiffness = 5000;   ///< N m/rad of the latch bolt against the strike
  double latch_damping = 200;      ///< N m s/rad
  bool latch_jammed = false;       ///< a fault: the latch never releases, whatever the handle does
  bool handle_jammed = false;      ///< a fault: the handle is seized (its stop at 0.005 rad instead of
                                   ///< handle_max), so it cannot be pressed and the latch never releases
};

/// URDF text of a door: links door_frame (root, massless), door_leaf (joint "door_hinge", revolute about -z so
/// that opening is positive, limits [0, max_angle]) and door_handle (joint "door_handle_joint", revolute about
/// the leaf's x, pressing down is positive, limits [0, handle_max]), and door_grasp, a massless frame at the
/// grasp point of the bar. Throws std::invalid_argument if a dimension is out of range.
std::string door_urdf(const DoorParams& p);

}  // namespace dca::sim
