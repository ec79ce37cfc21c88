#pragma once
// The Lua module `dca.core`: the supervisor's whole view of the C++ core.
#include <vector>

#include "host/port.h"

struct lua_State;

namespace dca::bindings {
/// The robot process's signals as ports: its outputs (the sensors) and inputs (the commands). An executable that
/// has the world registers them (app/cmd_sim.cpp: sim/world.h's signals); `core.world_signals()` gives them to
/// `dca check`, which holds the device ports to them. Without a registration it gives nil.
struct WorldSignals {
  std::vector<PortSpec> outputs, inputs;
};
/// Registers the world's signals (once, at static initialisation).
void set_world_signals(WorldSignals s);
}  // namespace dca::bindings

extern "C" {
/// Opens `dca.core` (registered in package.preload by dca::lua::Runtime).
int luaopen_dca_core(lua_State* L);
}
