#pragma once
// `dca sim --world ROBOT.urdf` and `--world mock:ROBOT.urdf` (docs/robots.md): the generic URDF world, run here or
// served as the world process (sim/device_node.h); and `dca types --world SPEC`: the ports it would have.
#include <string>
#include <vector>

#include "host/port.h"

namespace dca::app {

/// What `dca sim` hands a robot world.
struct RobotSimOptions {
  std::string world;                 ///< the spec (sim/urdf/joint_world.h)
  bool serve = false, go = false, realtime = false;
  std::string daemon, name = "world", key, host, trace;
  std::string record;                ///< served: the MCAP file (sim/device_node.h)
  double period = 1e-3, duration = -1, sync_period = 0.01, record_period = 0.01;
  int tick_timeout_ms = 10000;
};

/// Whether `spec` names a robot world rather than the door.
bool is_robot_world(const std::string& spec);
/// Runs the robot world: served (--serve) or stepped here for --duration (default 1 s) with no commands, then
/// its joints and the safety layer's summary printed. The exit code.
int sim_robot(const RobotSimOptions& o);
/// The ports robot world `spec` serves, from its URDF (loaded, not simulated; a mock's options checked as the
/// mock checks them): its outputs and inputs. False with *error (the URDF's FILE:LINE:COL, or the spec's fault).
bool robot_world_signals(const std::string& spec, std::vector<PortSpec>* outputs, std::vector<PortSpec>* inputs,
                         std::string* error);
/// Prints the ports of world `spec` (as `dca types` prints a controller's) and its warnings: the exit code.
int print_world_ports(const std::string& spec);

}  // namespace dca::app
