#include "app/node_run.h"

#include <csignal>

namespace dca::app {

std::string run_node(Loop& loop, Node& node, const std::function<void()>& on_ready, bool* ready) {
  loop.on_signals({SIGTERM, SIGINT}, [&](int) { loop.stop(); });
  bool started = false;
  std::string failure;
  node.start([&](const std::string& error) {
    if (!error.empty()) {
      failure = error;
      loop.stop();
      return;
    }
    started = true;
    on_ready();
  });
  loop.run();
  if (ready != nullptr) *ready = started;
  return failure;
}

}  // namespace dca::app
