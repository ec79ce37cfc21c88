#pragma once
// `dca types --world WORLD` (app/world_urdf.cpp): the ports a world serves.
#include <string>

namespace dca::app {

/// Prints the ports of world `spec` (as `dca types` prints a controller's) and what loading it said: the exit code.
int types_of_world(const std::string& spec);

}  // namespace dca::app
