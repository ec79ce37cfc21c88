#pragma once
// The Lua module `dca.core`: the supervisor's whole view of the C++ core.
#include <string>
#include <vector>

#include "host/port.h"

struct lua_State;

namespace dca::bindings {
/// The robot process's signals as ports: its outputs (the sensors) and inputs (the commands). An executable that
/// has the worlds registers where they come from (app/cmd_sim.cpp: the door's, sim/world.h; a URDF's, loaded by
/// sim/urdf); `core.world_signals(SPEC)` gives them to `dca check`, which holds the device ports to them.
/// Without a registration it gives nil.
struct WorldSignals {
  std::vector<PortSpec> outputs, inputs;
};
/// The signals of world `spec` (what `dca run --sim` takes: "door", ROBOT.urdf, mock:ROBOT.urdf?...): false with
/// *error saying why there are none (a URDF's FILE:LINE:COL). Throws nothing.
using WorldSignalsSource = bool (*)(const std::string& spec, WorldSignals* out, std::string* error);
/// Registers the source of the worlds' signals (once, at static initialisation).
void set_world_signals(WorldSignalsSource source);
}  // namespace dca::bindings

extern "C" {
/// Opens `dca.core` (registered in package.preload by dca::lua::Runtime).
int luaopen_dca_core(lua_State* L);
}
