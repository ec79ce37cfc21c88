// `dca node`: one controller in its own process, or a shared node hosting the leaves its supervisors add, driven by
// their supervisors (host/node.h).
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <cstring>
#include <string>

#include "controllers/packages.h"
#include <dca/registry.h>
#include "app/node_run.h"
#include "app/subcommand.h"
#include "host/loop.h"
#include "host/paths.h"
#include "host/node.h"
#include "host/rt/setup.h"

namespace dca::cli::cmd_node {
namespace {

constexpr const char* kUsage =
    "usage: dca node --type T --name PATH --daemon ADDR [--key FILE] [--host NAME] [--clock wall|sim]\n"
    "                [--world NAME|none] [--timeout MS] [--package NAME]... [--system-dir DIR]\n"
    "                [--rt-priority P] [--rt-cpu C] [-- ARG...]\n"
    "       dca node --shared NAME --daemon ADDR [--key FILE] [--host NAME] [--clock wall|sim] ...\n"
    "\n"
    "Hosts one controller of type T (see `dca types`) named PATH: registers it with the daemon at ADDR, then\n"
    "waits, inactive, for its supervisor's init / run / stop / connect / activate / deactivate / read / ports\n"
    "requests on the control address it registered (host/node.h lists them). ARG are the controller's .dca\n"
    "arguments after the host. The daemon (`dca daemon`) normally starts it.\n"
    "With --shared, the node hosts no leaf at first and registers as NAME#PID; its supervisors add leaves with\n"
    "`add {controller, name, args}` and end them with `remove {name}` (dca run --placement group|host).\n"
    "  --key FILE     the cluster key (default: $DCA_KEY_FILE, else ~/.config/dca/key)\n"
    "  --host NAME    its logical host (default: the daemon's)\n"
    "  --clock sim    simulated time: subscribes to the clock master (the world) and obeys its `advance {t}`\n"
    "                 requests in lock-step (host/node.h, host/timers.h)\n"
    "  --world NAME   the clock master's registered name (default `world`; `none`: any control channel may\n"
    "                 advance the clock, for tests)\n"
    "  --timeout MS   deadline of each start-up step and look-up (default 5000)\n"
    "  --package NAME load the controller package NAME first (repeatable): NAME.dca.so from $DCA_CONTROLLER_PATH,\n"
    "                 <prefix>/lib/dca/controllers, or DIR/packages with --system-dir DIR (the .dca file's folder)\n"
    "  --rt-priority P, --rt-cpu C  wall clock only: the leaves run on a real-time thread of the node's, SCHED_FIFO\n"
    "                 P (1..99), pinned to CPU C, memory locked; sockets and requests stay on its I/O thread\n"
    "                 (docs/time.md, \"Real time\"); without the privilege, one warning and the default\n"
    "                 scheduler, on that thread still. Ignored on simulated time.\n"
    "Prints `dca node: PATH ready` on stdout once registered. Exits 0 on `exit` or SIGTERM, 1 when start-up\n"
    "fails or the daemon goes away.";

// Loads the packages named on the command line (the types of the leaves this node hosts). False after saying why.
bool load_packages(const std::vector<std::string>& names, const std::string& system_dir) {
  const auto dirs = dca::controller_dirs(system_dir);
  for (const auto& n : names) {
    std::string error;
    if (!dca::load_package(n, dirs, &error)) {
      std::fprintf(stderr, "dca node: %s\n", error.c_str());
      return false;
    }
  }
  return true;
}

// Real time on the wall clock: a valid setting goes to the node, whose leaves then run on a real-time thread
// (host/node_rt.h, which sets it up and warns once when refused); an invalid one is a warning and not applied.
// Nothing on simulated time, where runs stay trace-identical.
std::string take_rt(dca::NodeOptions& o, dca::rt::RtConfig rt) {
  if (o.clock != dca::ClockKind::Wall || (rt.priority == 0 && rt.cpu < 0)) return "";
  char host[256] = {};
  gethostname(host, sizeof host - 1);
  rt.who = o.name + " on host " + (o.host.empty() ? std::string(host) : o.host);
  if (auto e = dca::rt::check(rt); !e.empty()) return dca::rt::warning(rt, e + ": not applied");
  o.rt = rt;
  return "";
}

int cmd_node(std::span<char* const> args) {
  dca::NodeOptions o;
  dca::rt::RtConfig rt;
  std::vector<std::string> packages;
  std::string system_dir;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string a = args[i];
    if (a == "--") {
      for (++i; i < args.size(); ++i) o.args.emplace_back(args[i]);
      break;
    }
    if (i + 1 >= args.size()) {
      std::fprintf(stderr, "dca node: %s\n%s\n",
                   a.rfind("--", 0) == 0 ? (a + " needs a value").c_str() : ("unexpected argument '" + a + "'").c_str(),
                   kUsage);
      return 2;
    }
    const std::string v = args[++i];
    if (a == "--type") o.type = v;
    else if (a == "--name") o.name = v;
    else if (a == "--shared") o.name = v, o.shared = true;
    else if (a == "--daemon") o.daemon = v;
    else if (a == "--key") o.key_file = v;
    else if (a == "--host") o.host = v;
    else if (a == "--world") o.world = v == "none" ? std::string() : v;
    else if (a == "--timeout") o.timeout_ms = std::atoi(v.c_str());
    else if (a == "--package") packages.push_back(v);
    else if (a == "--system-dir") system_dir = v;
    else if (a == "--rt-priority") rt.priority = std::atoi(v.c_str());
    else if (a == "--rt-cpu") rt.cpu = std::atoi(v.c_str());
    else if (a == "--clock" && (v == "wall" || v == "sim")) o.clock = v == "sim" ? dca::ClockKind::Simulated : dca::ClockKind::Wall;
    else {
      std::fprintf(stderr, "dca node: unknown argument '%s %s'\n%s\n", a.c_str(), v.c_str(), kUsage);
      return 2;
    }
  }
  if ((o.type.empty() && !o.shared) || o.name.empty() || o.daemon.empty()) {
    std::fprintf(stderr, "dca node: --type, --name (or --shared) and --daemon are required\n%s\n", kUsage);
    return 2;
  }
  if (o.timeout_ms <= 0) o.timeout_ms = 5000;
  if (!load_packages(packages, system_dir)) return 1;
  if (const auto w = take_rt(o, rt); !w.empty()) std::fprintf(stderr, "dca node: %s\n", w.c_str());
  o.load_package = [](const std::string& name, const std::string& dir, std::string* error) {
    return dca::load_package(name, dca::controller_dirs(dir), error) != nullptr;
  };
  o.package_changed = [](const std::string& name, const std::string& dir) {
    return dca::package_changed(name, dca::controller_dirs(dir));
  };
  dca::Loop loop;
  dca::Node node(loop, o,
                 [](const std::string& type, const std::string& name, const std::string& host,
                    const std::vector<std::string>& params, dca::TimerServer& timers) -> std::unique_ptr<dca::Component> {
                   return dca::Registry::global().create_or_stand_in(type, {name, host, params, &timers, nullptr});
                 });
  bool started = false;
  std::string failure;
  dca::app::run_node(loop, node, [&] {
    std::printf("dca node: %s ready\n", o.shared ? (o.name + "#" + std::to_string(::getpid())).c_str() : o.name.c_str());
    std::fflush(stdout);
  }, &started, &failure);
  if (!started) {
    // (a reason the daemon took is in its log and goes to the supervisor: not said twice)
    if (!node.failure_told())
      std::fprintf(stderr, "dca node %s: %s\n", o.name.c_str(), failure.empty() ? "stopped before it was ready" : failure.c_str());
    node.shutdown("start-up failed");
    return 1;
  }
  node.shutdown("node exiting");
  return node.exit_code();
}

}  // namespace

DCA_SUBCOMMAND("node", "host one controller, driven by its supervisor (started by a daemon)", kUsage, cmd_node);

}  // namespace dca::cli::cmd_node
