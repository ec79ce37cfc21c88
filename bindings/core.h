#pragma once
// The Lua module `dca.core`: the supervisor's whole view of the C++ core.
#include <string>
#include <utility>
#include <vector>

#include "host/port.h"

struct lua_State;

namespace dca::bindings {
/// The robot process's signals as ports: its outputs (the sensors) and inputs (the commands). An executable that
/// has the worlds registers where they come from (app/cmd_sim.cpp, from the world plug-ins: sim/world_plugin.h);
/// `core.world_signals(SPEC, OPTIONS)` gives them to `dca check`, which holds the device ports to them, and to
/// `dca run`, which checks the world's options before anything starts. Without a registration it gives nil.
struct WorldSignals {
  std::vector<PortSpec> outputs, inputs;
  /// Inputs that drive another input's actuator (a joint's alias beside its drive's vector): {input, actuator}.
  std::vector<std::pair<std::string, std::string>> actuators;
  std::string world;  ///< the world's spec ("" asked: the default world's name)
};
/// The signals of world `spec` ("" : the default world; a world's name, ROBOT.urdf, mock:ROBOT.urdf?...) with
/// its options `options` ("KEY=VALUE" texts) checked: false with *error saying why there are none (an unknown
/// world or option, a URDF's FILE:LINE:COL). Throws nothing.
using WorldSignalsSource = bool (*)(const std::string& spec, const std::vector<std::string>& options,
                                    WorldSignals* out, std::string* error);
/// Registers the source of the worlds' signals (once, at static initialisation).
void set_world_signals(WorldSignalsSource source);
}  // namespace dca::bindings

extern "C" {
/// Opens `dca.core` (registered in package.preload by dca::lua::Runtime).
int luaopen_dca_core(lua_State* L);
}
