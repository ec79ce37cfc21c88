#pragma once
// The ports that most of the door's controllers have, defined once (dca/robot/signals.h: the signals). Each
// controller's other ports and parameters are in its own file, named so that no two files of the package share a
// name: the project builds the package as a unity build, its files joined in batches.
#include <dca/robot/signals.h>

namespace dca::door {

inline const InSpec<robot::Vec6> kJoints = robot::JointsIn();
inline const InSpec<robot::Vec6> kWrench = robot::WrenchIn();
inline const OutSpec<robot::Vec9> kVel = actuator(robot::VelOut());

}  // namespace dca::door
