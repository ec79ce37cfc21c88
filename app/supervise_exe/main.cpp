// dca-supervise: `dca supervise` on its own (lua/dca/cli/supervise.lua), linked without Simbody, so that a
// group's supervisor process starts sooner: dynamic loading of the whole `dca` executable took about half of
// its start-up (bench: supervisor_bench, 1,000 leaves in 100 groups). The daemon's Executer runs it for
// `dca supervise ...` when it sits beside `dca` (host/exec.h). Accepts the same arguments, with or without the
// leading word `supervise`.
#include <cstdio>
#include <exception>
#include <span>
#include <string>

#include "bindings/lua_runtime.h"
#include "bindings/stop_signals.h"
#include "host/spawn.h"

int main(int argc, char** argv) {
  dca::die_with_parent();
  dca::bindings::hold_stop_signals();  // as `dca supervise`: a stop signal from the first instant is kept
  int first = 1;
  if (argc > 1 && std::string(argv[1]) == "supervise") first = 2;
  try {
    dca::lua::Runtime rt;
    return rt.run_module_main("dca.cli.supervise",
                              std::span<char* const>(argv + first, static_cast<std::size_t>(argc - first)));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dca-supervise: %s\n", e.what());
    return 1;
  }
}
