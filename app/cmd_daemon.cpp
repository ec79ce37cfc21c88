// `dca daemon`: the per-host services (Executer, NameServer) on one authenticated channel listener.
#include <sys/resource.h>
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <set>
#include <string>
#include <system_error>
#include <vector>

#include "app/subcommand.h"
#include "host/daemon.h"
#include "host/loop.h"
#include "host/paths.h"
#include "host/systemd.h"

namespace dca::cli::cmd_daemon {
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
    "  --state-dir DIR  where the configuration replica lives (DIR/config.db; one daemon per DIR), and the\n"
    "                   package versions a rolling upgrade installed (DIR/packages, `dca upgrade`). Default:\n"
    "                   $XDG_STATE_HOME/dca/HOST, else ~/.local/state/dca/HOST (when another daemon holds the\n"
    "                   default, this one runs without a repository and says so). `none`: no repository.\n"
    "                   A corrupt database makes the daemon refuse to start, naming the file.\n"
    "  --sync-ms MS     anti-entropy period with the peers (default 2000)\n"
    "  --remove-on-exit DIR  remove DIR (a whole tree) when this daemon stops after the process that started\n"
    "                   it died (`dca run` passes its temporary directory; repeatable)\n"
    "\n"
    "When ready it prints one line on stdout: `dca daemon: host NAME listening on ADDR`.\n"
    "SIGTERM or SIGINT stops it: every child's process group is killed and reaped first.";

// The command line, parsed: the daemon's options and what only the command resolves.
struct Args {
  dca::DaemonOptions o;
  std::string key_file;
  std::string state_dir;
  bool state_dir_given = false;
  std::vector<std::string> remove_on_exit;
};

// Applies option `a` (one that takes a value) with value `v`: false, after printing why, when `v` is wrong.
bool apply_option(const std::string& a, const char* v, Args& p) {
  std::string error;
  if (a == "--host") {
    p.o.host = v;
  } else if (a == "--listen" || a == "--peer") {
    auto addr = dca::Address::parse(v, &error);
    if (!addr) {
      std::fprintf(stderr, "dca daemon: %s %s\n", a.c_str(), error.c_str());
      return false;
    }
    if (a == "--listen") p.o.listen = *addr; else p.o.peers.push_back(*addr);
  } else if (a == "--key") {
    p.key_file = v;
  } else if (a == "--allow") {
    if (v[0] != '/') {
      std::fprintf(stderr, "dca daemon: --allow needs an absolute path, not '%s'\n", v);
      return false;
    }
    p.o.allow.allow(v);
  } else if (a == "--clock") {
    if (std::string(v) != "wall" && std::string(v) != "sim") {
      std::fprintf(stderr, "dca daemon: --clock must be wall or sim, not '%s'\n", v);
      return false;
    }
    p.o.sim_clock = std::string(v) == "sim";
  } else if (a == "--state-dir") {
    p.state_dir = v;
    p.state_dir_given = true;
  } else if (a == "--remove-on-exit") {
    if (v[0] != '/') {
      std::fprintf(stderr, "dca daemon: --remove-on-exit needs an absolute path, not '%s'\n", v);
      return false;
    }
    p.remove_on_exit.emplace_back(v);
  } else if (a == "--sync-ms") {
    if (std::atol(v) <= 0) {
      std::fprintf(stderr, "dca daemon: --sync-ms needs a positive number of milliseconds, not '%s'\n", v);
      return false;
    }
    p.o.config_sync_interval = std::chrono::milliseconds(std::atol(v));
  } else {  // --grace
    p.o.stop_grace = std::chrono::milliseconds(std::atol(v));
  }
  return true;
}

// Parses argv into `p` (the host defaults to the machine's name): 0, or 2 after printing the usage error.
int parse(std::span<char* const> args, Args& p) {
  char hostname[256] = {};
  if (::gethostname(hostname, sizeof hostname - 1) == 0 && hostname[0] != '\0') p.o.host = hostname;
  static const std::set<std::string> kOptions = {"--host",  "--listen",    "--peer",    "--key",  "--allow",
                                                  "--clock", "--state-dir", "--sync-ms", "--grace",
                                                  "--remove-on-exit"};
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string a = args[i];
    if (kOptions.count(a) == 0) {
      std::fprintf(stderr, "dca daemon: unknown argument '%s'\n%s\n", a.c_str(), kUsage);
      return 2;
    }
    if (i + 1 >= args.size()) {
      std::fprintf(stderr, "dca daemon: %s needs a value\n%s\n", a.c_str(), kUsage);
      return 2;
    }
    if (!apply_option(a, args[++i], p)) return 2;
  }
  return 0;
}

// Resolves the state directory's default and loads (or creates) the key: false after printing why.
bool resolve(Args& p) {
  if (!p.state_dir_given) {
    p.state_dir = dca::state_dir(p.o.host);
    p.o.state_dir_is_default = true;
  }
  if (p.state_dir != "none") p.o.state_dir = p.state_dir;
  std::string error;
  const auto key = dca::auth::load_or_create_key(dca::auth::key_file_path(p.key_file), &error);
  if (!key) {
    dca::systemd::log(dca::systemd::Priority::err, "dca daemon: %s", error.c_str());
    return false;
  }
  p.o.key = *key;
  return true;
}

// Raises the soft limit on open descriptors to the hard one (a daemon holds one per connection and per child,
// and the common default of 1024 is low for that) and says on stderr what it got.
void raise_descriptor_limit(const std::string& host) {
  rlimit r{};
  if (::getrlimit(RLIMIT_NOFILE, &r) != 0) return;
  const rlim_t before = r.rlim_cur;
  if (r.rlim_cur < r.rlim_max) {
    r.rlim_cur = r.rlim_max;
    if (::setrlimit(RLIMIT_NOFILE, &r) != 0) r.rlim_cur = before;
  }
  const auto text = [](rlim_t v) { return v == RLIM_INFINITY ? std::string("unlimited") : std::to_string(v); };
  dca::systemd::log(dca::systemd::Priority::info,
                    "dca daemon: host %s descriptors: soft limit %s (was %s, hard limit %s)", host.c_str(),
                    text(r.rlim_cur).c_str(), text(before).c_str(), text(r.rlim_max).c_str());
}

// Runs the daemon until SIGTERM, SIGINT or SIGHUP, then stops its children: the exit code.
int run(const dca::DaemonOptions& o, const std::vector<std::string>& remove_on_exit) {
  const pid_t parent = ::getppid();
  raise_descriptor_limit(o.host);
  dca::Loop loop;
  // under systemd (Type=notify): takes NOTIFY_SOCKET & co. out of the environment before any child starts
  dca::systemd::Notifier notifier;
  dca::Daemon daemon(loop.io(), o);
  std::string error;
  if (!daemon.start(&error)) {
    dca::systemd::log(dca::systemd::Priority::err, "dca daemon: host %s: %s", o.host.c_str(), error.c_str());
    return 1;
  }
  int stop_signal = 0;
  loop.on_signals({SIGTERM, SIGINT, SIGHUP}, [&](int sig) {
    stop_signal = sig;
    loop.stop();
  });
  std::signal(SIGPIPE, SIG_IGN);
  if (auto* c = daemon.config(); c != nullptr && c->store() != nullptr) {
    dca::systemd::log(dca::systemd::Priority::info, "dca daemon: host %s configuration replica %s (%s)", o.host.c_str(),
                      c->path().c_str(), c->store()->origin().c_str());
  }
  std::printf("dca daemon: host %s listening on %s\n", o.host.c_str(), daemon.address().str().c_str());
  std::fflush(stdout);
  // READY=1 from the running loop, which accepts connections; WATCHDOG=1 from it (docs/deploy.md)
  boost::asio::post(loop.io(), [&] {
    notifier.ready(loop.io(), "host " + o.host + " listening on " + daemon.address().str());
  });
  loop.run();
  const std::string stopping = "host " + o.host + " stopping (" +
                               (stop_signal ? dca::signal_name(stop_signal) : std::string("its loop ended")) + "): " +
                               std::to_string(daemon.executer().running()) + " children to stop";
  notifier.stopping(stopping);
  dca::systemd::log(dca::systemd::Priority::notice, "dca daemon: %s", stopping.c_str());
  // orphaned (the process that started us died, e.g. `dca run` by SIGKILL): nobody waits for an orderly stop, and
  // everything of the run must be gone within 2 s, so the children get a short grace
  const bool orphaned = ::getppid() != parent;
  if (orphaned) daemon.executer().stop_all(std::chrono::milliseconds(300));
  daemon.stop();
  // Let the close notices reach the peers (bounded).
  loop.run_for(std::chrono::milliseconds(50));
  if (orphaned) {  // nobody else removes the temporary directories of the run
    for (const auto& dir : remove_on_exit) {
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
    }
  }
  return 0;
}

int cmd_daemon(std::span<char* const> args) {
  Args p;
  if (const int code = parse(args, p); code != 0) return code;
  if (!resolve(p)) return 1;
  return run(p.o, p.remove_on_exit);
}

}  // namespace

DCA_SUBCOMMAND("daemon", "run this host's daemon (Executer, NameServer, configuration replica)", kUsage, cmd_daemon);

}  // namespace dca::cli::cmd_daemon
