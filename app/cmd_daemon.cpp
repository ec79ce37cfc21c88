// `dca daemon`: the per-host services (Executer, NameServer) on one authenticated channel listener.
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <string>

#include "app/subcommand.h"
#include "host/daemon.h"
#include "host/loop.h"
#include "host/paths.h"

namespace {

constexpr const char* kUsage =
    "usage: dca daemon [--host NAME] [--listen ADDR] [--peer ADDR]... [--key FILE] [--allow PROGRAM]...\n"
    "                  [--clock wall|sim] [--grace MS] [--state-dir DIR|none] [--sync-ms MS]\n"
    "\n"
    "Runs this host's daemon: the Executer (starts allow-listed programs, reports their exit) and the\n"
    "NameServer (register / look up names; look-ups not known here are asked of the peers) and the\n"
    "configuration repository (a SQLite replica, replicated with the peers; `dca config`).\n"
    "\n"
    "  --host NAME      this host's logical name (default: the machine's host name)\n"
    "  --listen ADDR    127.0.0.1:PORT (port 0 picks a free one; the default is 127.0.0.1:0),\n"
    "                   [::1]:PORT, or unix:/PATH\n"
    "  --peer ADDR      another daemon to ask for names (repeatable)\n"
    "  --key FILE       the cluster key file (mode 0600; created when missing). Default: $DCA_KEY_FILE,\n"
    "                   else $XDG_CONFIG_HOME/dca/key, else ~/.config/dca/key\n"
    "  --allow PROGRAM  also allow spawning PROGRAM (an absolute path) with any arguments (repeatable;\n"
    "                   for tests and benchmarks). By default only `dca node|supervise|sim` may be spawned.\n"
    "  --clock sim      this host runs on simulated time: every `dca node` it spawns gets --clock sim (and\n"
    "                   takes its clock from the world, `dca sim --serve`) unless its argv names a clock\n"
    "  --grace MS       at stop, how long children get between SIGTERM and SIGKILL (default 2000)\n"
    "  --state-dir DIR  where the configuration replica lives (DIR/config.db; one daemon per DIR). Default:\n"
    "                   $XDG_STATE_HOME/dca/HOST, else ~/.local/state/dca/HOST (when another daemon holds the\n"
    "                   default, this one runs without a repository and says so). `none`: no repository.\n"
    "                   A corrupt database makes the daemon refuse to start, naming the file.\n"
    "  --sync-ms MS     anti-entropy period with the peers (default 2000)\n"
    "\n"
    "When ready it prints one line on stdout: `dca daemon: host NAME listening on ADDR`.\n"
    "SIGTERM or SIGINT stops it: every child's process group is killed and reaped first.";

int cmd_daemon(std::span<char* const> args) {
  dca::DaemonOptions o;
  char hostname[256] = {};
  if (::gethostname(hostname, sizeof hostname - 1) == 0 && hostname[0] != '\0') o.host = hostname;
  std::string key_file;
  std::string state_dir;
  bool state_dir_given = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string a = args[i];
    const auto value = [&]() -> const char* {
      if (i + 1 >= args.size()) {
        std::fprintf(stderr, "dca daemon: %s needs a value\n%s\n", a.c_str(), kUsage);
        return nullptr;
      }
      return args[++i];
    };
    std::string error;
    if (a == "--host") {
      const char* v = value();
      if (v == nullptr) return 2;
      o.host = v;
    } else if (a == "--listen" || a == "--peer") {
      const char* v = value();
      if (v == nullptr) return 2;
      auto addr = dca::Address::parse(v, &error);
      if (!addr) {
        std::fprintf(stderr, "dca daemon: %s %s\n", a.c_str(), error.c_str());
        return 2;
      }
      if (a == "--listen") {
        o.listen = *addr;
      } else {
        o.peers.push_back(*addr);
      }
    } else if (a == "--key") {
      const char* v = value();
      if (v == nullptr) return 2;
      key_file = v;
    } else if (a == "--allow") {
      const char* v = value();
      if (v == nullptr) return 2;
      if (v[0] != '/') {
        std::fprintf(stderr, "dca daemon: --allow needs an absolute path, not '%s'\n", v);
        return 2;
      }
      o.allow.allow(v);
    } else if (a == "--clock") {
      const char* v = value();
      if (v == nullptr) return 2;
      if (std::string(v) != "wall" && std::string(v) != "sim") {
        std::fprintf(stderr, "dca daemon: --clock must be wall or sim, not '%s'\n", v);
        return 2;
      }
      o.sim_clock = std::string(v) == "sim";
    } else if (a == "--state-dir") {
      const char* v = value();
      if (v == nullptr) return 2;
      state_dir = v;
      state_dir_given = true;
    } else if (a == "--sync-ms") {
      const char* v = value();
      if (v == nullptr) return 2;
      if (std::atol(v) <= 0) {
        std::fprintf(stderr, "dca daemon: --sync-ms needs a positive number of milliseconds, not '%s'\n", v);
        return 2;
      }
      o.config_sync_interval = std::chrono::milliseconds(std::atol(v));
    } else if (a == "--grace") {
      const char* v = value();
      if (v == nullptr) return 2;
      o.stop_grace = std::chrono::milliseconds(std::atol(v));
    } else {
      std::fprintf(stderr, "dca daemon: unknown argument '%s'\n%s\n", a.c_str(), kUsage);
      return 2;
    }
  }
  if (!state_dir_given) {
    state_dir = dca::state_dir(o.host);
    o.state_dir_is_default = true;
  }
  if (state_dir != "none") o.state_dir = state_dir;
  const std::string path = dca::auth::key_file_path(key_file);
  std::string error;
  const auto key = dca::auth::load_or_create_key(path, &error);
  if (!key) {
    std::fprintf(stderr, "dca daemon: %s\n", error.c_str());
    return 1;
  }
  o.key = *key;

  dca::Loop loop;
  dca::Daemon daemon(loop.io(), o);
  if (!daemon.start(&error)) {
    std::fprintf(stderr, "dca daemon: host %s: %s\n", o.host.c_str(), error.c_str());
    return 1;
  }
  int stop_signal = 0;
  loop.on_signals({SIGTERM, SIGINT, SIGHUP}, [&](int sig) {
    stop_signal = sig;
    loop.stop();
  });
  std::signal(SIGPIPE, SIG_IGN);
  if (auto* c = daemon.config(); c != nullptr && c->store() != nullptr) {
    std::fprintf(stderr, "dca daemon: host %s configuration replica %s (%s)\n", o.host.c_str(), c->path().c_str(),
                 c->store()->origin().c_str());
  }
  std::printf("dca daemon: host %s listening on %s\n", o.host.c_str(), daemon.address().str().c_str());
  std::fflush(stdout);
  loop.run();
  std::fprintf(stderr, "dca daemon: host %s stopping (%s): %zu children to stop\n", o.host.c_str(),
               stop_signal ? dca::signal_name(stop_signal).c_str() : "its loop ended", daemon.executer().running());
  daemon.stop();
  // Let the close notices reach the peers (bounded).
  loop.run_for(std::chrono::milliseconds(50));
  return 0;
}

}  // namespace

DCA_SUBCOMMAND("daemon", "run this host's daemon (Executer, NameServer, configuration replica)", kUsage, cmd_daemon);
