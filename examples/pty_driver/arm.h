#pragma once
// The arm that examples/pty_driver drives: six revolute joints with the names, limits and start pose of
// worlds/ur10/ur10.urdf (a UR10), known to the driver (its ports, its limits) and to the simulated device.
#include <array>
#include <cstddef>

namespace pty_driver {

inline constexpr std::size_t kJoints = 6;

/// One joint: its URDF name, its soft position limits (rad: 0.05 inside the hard ones, as the URDF's
/// <safety_controller>), its velocity limit (rad/s) and where it starts (rad).
struct JointInfo {
  const char* name;
  double lower, upper, velocity, start;
};

inline constexpr std::array<JointInfo, kJoints> kArm{{
    {"shoulder_pan_joint", -6.23318530717959, 6.23318530717959, 2.0944, 0},
    {"shoulder_lift_joint", -6.23318530717959, 6.23318530717959, 2.0944, -1.5707963267949},
    {"elbow_joint", -3.09159265358979, 3.09159265358979, 3.1416, 1.5707963267949},
    {"wrist_1_joint", -6.23318530717959, 6.23318530717959, 3.1416, -1.5707963267949},
    {"wrist_2_joint", -6.23318530717959, 6.23318530717959, 3.1416, -1.5707963267949},
    {"wrist_3_joint", -6.23318530717959, 6.23318530717959, 3.1416, 0},
}};

}  // namespace pty_driver
