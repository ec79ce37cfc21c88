// dca-node: `dca node` on its own (host/node.h), without Simbody, Lua or the REPL, so that a controller's
// process starts in a fraction of the time the whole `dca` executable takes (its dynamic loading of Simbody
// dominated spawn-to-ready). The daemon's Executer runs it for `dca node ...` when it sits beside `dca`
// (host/exec.h). Accepts the same arguments, with or without the leading word `node`.
#include <cstdio>
#include <span>
#include <string>

#include "app/subcommand.h"
#include "host/spawn.h"

int main(int argc, char** argv) {
  dca::die_with_parent();
  const auto* node = dca::cli::find("node");
  if (node == nullptr) {
    std::fprintf(stderr, "dca-node: built without the node subcommand\n");
    return 2;
  }
  int first = 1;
  if (argc > 1 && std::string(argv[1]) == "node") first = 2;
  return node->main(std::span<char* const>(argv + first, static_cast<std::size_t>(argc - first)));
}
