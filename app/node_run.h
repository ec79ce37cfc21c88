#pragma once
// Running a node to its end, shared by `dca node` and `dca sim --serve`.
#include <functional>
#include <string>

#include "host/loop.h"
#include "host/node.h"

namespace dca::app {

/// Starts `node`, then runs `loop` until it stops (SIGTERM and SIGINT stop it too); `on_ready` runs once the
/// node has registered. Returns false, with why in *error, when the start-up failed; `*ready` tells whether the
/// node got ready (false too when a signal stopped it first).
bool run_node(Loop& loop, Node& node, const std::function<void()>& on_ready, bool* ready, std::string* error);

}  // namespace dca::app
