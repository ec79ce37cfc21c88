#include "controllers/robot/signals.h"

namespace dca::robot {

PortSpec device(PortSpec p, std::string signal) {
  p.device = std::move(signal);
  return p;
}

PortSpec VelPort(std::string name) { return vector_port(std::move(name), 9, "Vel"); }
PortSpec JointsPort(std::string name) { return vector_port(std::move(name), 6, "rad"); }
PortSpec WrenchPort(std::string name) { return vector_port(std::move(name), 6, "N, N m"); }
PortSpec PosePort(std::string name) { return vector_port(std::move(name), 3, "m, m, rad"); }
PortSpec FeaturePort(std::string name) { return vector_port(std::move(name), 3, "px, px, 1"); }

ParamSpec HoldParam() {
  return ParamSpec::Optional("hold", "number", "0.01", "a command older than this (s) counts as zero (a drive's deadman)");
}

}  // namespace dca::robot
