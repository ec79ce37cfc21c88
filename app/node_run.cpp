#include "app/node_run.h"

#include <csignal>

namespace dca::app {

bool run_node(Loop& loop, Node& node, const std::function<void()>& on_ready, bool* ready, std::string* error) {
  loop.on_signals({SIGTERM, SIGINT}, [&](int) { loop.stop(); });
  bool started = false;
  std::string failure;
  node.start([&](const std::string& why) {
    if (!why.empty()) {
      failure = why;
      loop.stop();
      return;
    }
    started = true;
    on_ready();
  });
  loop.allow_spin();  // lock-step may ask a node (and the world, its master) to spin between rounds
  loop.run();
  *ready = started;
  if (failure.empty()) return true;
  *error = std::move(failure);
  return false;
}

}  // namespace dca::app
