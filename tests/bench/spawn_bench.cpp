// Spawn-to-exit time of /bin/true: through the Executer (allow-list check, posix_spawn in its own process
// group, pidfd watch on the loop, exit callback), through a daemon (spawn request on an authenticated channel
// -> exit event back on it), beside a raw posix_spawn + waitpid of /bin/true, in the same run, blocks
// alternating. Prints RESULT lines (BENCHMARKS.md); progress on stderr.
//   bench_spawn [spawns_per_block] [blocks]
#include <spawn.h>
#include <sys/wait.h>

#include "host/loop.h"  // first: Asio with GCC 12's false positive silenced
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

#include "host/daemon.h"
#include "host/exec.h"
#include "tests/bench/bench_util.h"

extern char** environ;

namespace {

using Clock = std::chrono::steady_clock;
using dca::wire::Message;
using dca::wire::Value;

const std::string kKey = "benchmark key, 32 bytes long....";

double us_since(Clock::time_point t0) { return std::chrono::duration<double, std::micro>(Clock::now() - t0).count(); }

void raw_block(int n, std::vector<double>* out) {
  char prog[] = "/bin/true";
  char* argv[] = {prog, nullptr};
  for (int i = 0; i < n; ++i) {
    const auto t0 = Clock::now();
    pid_t pid = 0;
    if (::posix_spawn(&pid, prog, nullptr, nullptr, argv, environ) != 0) std::exit(1);
    int st = 0;
    ::waitpid(pid, &st, 0);
    if (out != nullptr) out->push_back(us_since(t0));
  }
}

void executer_block(dca::Loop& loop, dca::Executer& ex, int n, std::vector<double>* out) {
  int done = 0;
  Clock::time_point t0;
  std::function<void()> next = [&] {
    t0 = Clock::now();
    std::string error;
    const auto c = ex.spawn({"/bin/true"}, [&](dca::Executer::ChildId, const dca::ExitStatus&) {
      if (out != nullptr) out->push_back(us_since(t0));
      if (++done < n) next();
    }, &error);
    if (!c) {
      std::fprintf(stderr, "spawn: %s\n", error.c_str());
      std::exit(1);
    }
  };
  next();
  loop.run_until([&] { return done >= n; }, std::chrono::seconds(120));
}

void daemon_block(dca::Loop& loop, dca::Channel& ch, int n, std::vector<double>* out) {
  int done = 0;
  Clock::time_point t0;
  std::function<void()> next = [&] {
    t0 = Clock::now();
    ch.request(Message{"spawn", 0, Value::map().set("argv", Value::Array{"/bin/true"})}, std::chrono::seconds(10),
               [](dca::Response r) {
                 if (!r.ok()) {
                   std::fprintf(stderr, "spawn: %s\n", r.error.c_str());
                   std::exit(1);
                 }
               });
  };
  ch.on_message([&](const Message& m) {
    if (m.type != "exit") return;
    if (out != nullptr) out->push_back(us_since(t0));
    if (++done < n) next();
  });
  next();
  loop.run_until([&] { return done >= n; }, std::chrono::seconds(120));
}

void print(const char* bench, std::vector<double>& v, const std::string& extra = "") {
  dca::bench::result(bench, "bin_true", v, extra);
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 200;
  const int blocks = argc > 2 ? std::atoi(argv[2]) : 4;
  dca::Loop loop;
  dca::AllowList allow;
  allow.allow("/bin/true");
  dca::Executer ex(loop.io(), allow);

  dca::DaemonOptions o;
  o.host = "bench";
  o.key = kKey;
  o.allow = allow;
  dca::Daemon daemon(loop.io(), o);
  std::string error;
  if (!daemon.start(&error)) {
    std::fprintf(stderr, "daemon: %s\n", error.c_str());
    return 1;
  }
  dca::Channel::Ptr ch;
  dca::Channel::connect(loop.io(), daemon.address(), dca::ChannelOptions{kKey},
                        [&](dca::Channel::Ptr c, const std::string&) { ch = c; });
  loop.run_until([&] { return ch != nullptr; }, std::chrono::seconds(10));
  if (!ch) return 1;

  std::vector<double> raw, exec, via_daemon;
  std::fprintf(stderr, "spawn: %d blocks of %d spawns of /bin/true each\n", blocks, n);
  raw_block(n / 10, nullptr);
  executer_block(loop, ex, n / 10, nullptr);
  daemon_block(loop, *ch, n / 10, nullptr);
  for (int b = 0; b < blocks; ++b) {
    raw_block(n, &raw);
    executer_block(loop, ex, n, &exec);
    daemon_block(loop, *ch, n, &via_daemon);
  }
  std::sort(raw.begin(), raw.end());
  std::sort(exec.begin(), exec.end());
  std::sort(via_daemon.begin(), via_daemon.end());
  char r1[64], r2[64];
  std::snprintf(r1, sizeof r1, " ratio_p50=%.2f", dca::bench::quantile(exec, 0.5) / std::max(1e-9, dca::bench::quantile(raw, 0.5)));
  std::snprintf(r2, sizeof r2, " ratio_p50=%.2f", dca::bench::quantile(via_daemon, 0.5) / std::max(1e-9, dca::bench::quantile(raw, 0.5)));
  print("dca_executer_spawn_exit", exec, r1);
  print("dca_daemon_spawn_exit", via_daemon, r2);
  print("raw_posix_spawn_exit", raw);
  ch->close();
  daemon.stop();
  return 0;
}
