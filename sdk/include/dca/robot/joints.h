#pragma once
// The device signals of a robot's joints (docs/robots.md, "Ports"; docs/drivers.md): the names under which the URDF
// world serves each joint's interfaces, and under which a real robot's driver serves them in its place, so that
// controllers find them by name whatever runs the robot.
//   joint.NAME.position, joint.NAME.velocity, joint.NAME.effort            state interfaces (outputs of the robot)
//   joint.NAME.position_command, .velocity_command, .effort_command         command interfaces (inputs of the robot)
#include <string>
#include <string_view>

namespace dca::robot {

/// A state interface's signal: "joint.NAME.INTERFACE" (INTERFACE: position, velocity or effort).
inline std::string joint_state_signal(std::string_view joint, std::string_view interface) {
  std::string s = "joint.";
  s.append(joint).append(".").append(interface);
  return s;
}

/// A command interface's signal: "joint.NAME.INTERFACE_command" (INTERFACE: position, velocity or effort).
inline std::string joint_command_signal(std::string_view joint, std::string_view interface) {
  return joint_state_signal(joint, interface).append("_command");
}

}  // namespace dca::robot
