#pragma once
// Running a node to its end, shared by `dca node` and `dca sim --serve`.
#include <functional>
#include <string>

#include "host/loop.h"
#include "host/node.h"

namespace dca::app {

/// Starts `node`, then runs `loop` until it stops (SIGTERM and SIGINT stop it too); `on_ready` runs once the
/// node has registered. Returns "" or why the start-up failed; `*ready` (when given) tells whether it got ready.
std::string run_node(Loop& loop, Node& node, const std::function<void()>& on_ready, bool* ready = nullptr);

}  // namespace dca::app
