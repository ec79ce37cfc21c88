// `dca bench rt [--seconds S] [--priority P] [--cpu C] [--no-load]`: the real-time thread (host/rt), and a node's
// (host/node_rt.h: a controller's timer on it), against cyclictest (Debian's rt-tests), in one run, alternately:
// idle, then under `stress-ng --cpu 2 --vm 1`. Each
// side wakes every 1 ms for S seconds (default 10) at SCHED_FIFO P (default 80; 0: the default scheduler),
// pinned to CPU C (default: the last), with memory locked. Prints the wake latency's p50/p99/p99.9/max and the
// overruns (dca: periods missed) side by side (docs/time.md, "Real time"; figures: tests/bench/RESULTS.md).
// A tool that is not installed is said so and left out; without the privilege both run unprivileged, warned.
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "app/subcommand.h"
#include "host/node_rt.h"
#include "host/rt/rt_thread.h"
#include "host/rt/setup.h"

extern char** environ;

namespace dca::cli::cmd_bench {
namespace {

struct Options {
  int seconds = 10, priority = 80, cpu = -1;
  bool load = true;
};

struct Row {
  std::string tool;
  std::uint64_t n = 0;
  double p50 = 0, p99 = 0, p999 = 0, max = 0;
  std::string overruns = "-";
};

dca::rt::RtConfig config(const Options& o) {
  dca::rt::RtConfig c;
  c.priority = o.priority;
  c.cpu = o.cpu;
  c.who = "dca bench rt";
  return c;
}

bool installed(const std::string& tool) {
  return std::system(("command -v " + tool + " >/dev/null 2>&1").c_str()) == 0;
}

// Quantiles of cyclictest's histogram (-h: lines "latency_us count"), its max from "# Max Latencies".
Row parse_cyclictest(const std::string& out) {
  Row r{.tool = "cyclictest"};
  std::vector<std::pair<long, std::uint64_t>> hist;
  std::istringstream in(out);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("# Max Latencies:", 0) == 0) r.max = std::strtod(line.c_str() + 16, nullptr);
    if (line.empty() || line[0] == '#') continue;
    long us = 0;
    unsigned long long c = 0;
    if (std::sscanf(line.c_str(), "%ld %llu", &us, &c) == 2 && c > 0) hist.emplace_back(us, c);
  }
  for (const auto& h : hist) r.n += h.second;
  const auto q = [&](double p) {
    std::uint64_t seen = 0, rank = static_cast<std::uint64_t>(p * static_cast<double>(r.n - 1)) + 1;
    for (const auto& h : hist)
      if ((seen += h.second) >= rank) return static_cast<double>(h.first);
    return r.max;
  };
  if (r.n) r = {r.tool, r.n, q(0.5), q(0.99), q(0.999), r.max, "-"};
  return r;
}

Row run_cyclictest(const Options& o) {
  std::string cmd = "cyclictest -q -m -i 1000 -h 20000 -l " + std::to_string(o.seconds * 1000) +
                    " -p " + std::to_string(o.priority) + " -a " + std::to_string(o.cpu) + " 2>&1";
  std::string out;
  if (FILE* f = popen(cmd.c_str(), "r")) {
    char buf[4096];
    for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;) out.append(buf, n);
    pclose(f);
  }
  return parse_cyclictest(out);
}

// The real-time thread at 1 kHz for o.seconds (its task does nothing: the wake-up path alone, as cyclictest's).
Row run_dca(const Options& o) {
  dca::rt::RtThread thread(config(o));
  thread.add("1kHz", 1'000'000, [] {});
  if (const auto w = thread.start(); !w.empty()) std::fprintf(stderr, "%s\n", w.c_str());
  std::this_thread::sleep_for(std::chrono::seconds(o.seconds));
  thread.stop();
  const auto s = thread.stats().at(0);
  return {"dca", s.wake.n, s.wake.p50_us, s.wake.p99_us, s.wake.p999_us, s.wake.max_us, std::to_string(s.missed)};
}

// A component whose run is a 1 kHz timer doing nothing.
class Tick final : public dca::Component {
 public:
  explicit Tick(dca::TimerServer& ts) : ts_(ts) {}
  const std::string& name() const override { return name_; }
  dca::PortSet& ports() override { return ports_; }
  bool configure(std::string*) override { return true; }
  bool start(dca::Bytes, std::string*) override {
    id_ = ts_.every(1'000'000, [] {}, name_);
    return true;
  }
  void halt() override {
    if (id_) ts_.cancel(id_);
    id_ = 0;
  }

 private:
  dca::TimerServer& ts_;
  std::string name_ = "1kHz";
  dca::PortSet ports_;
  dca::TimerServer::Id id_ = 0;
};

// A node's real-time thread (host/node_rt.h: what `rt { }` runs a controller on) with one such component for
// o.seconds: the wake-up path of a MainCalc, its timer driven by the thread, the rings and the I/O thread beside.
Row run_node(const Options& o) {
  boost::asio::io_context io;
  dca::RtHost host(io, config(o));
  Tick tick(host.timers());
  auto& mirror = host.adopt(tick, nullptr);
  (void)mirror;
  if (const auto w = host.start(); !w.empty()) std::fprintf(stderr, "%s\n", w.c_str());
  host.request(tick, dca::RtHost::Op::Start, "", "", [](const std::string& e) {
    if (!e.empty()) std::fprintf(stderr, "dca bench rt: %s\n", e.c_str());
  });
  io.run_for(std::chrono::seconds(o.seconds));
  const auto s = host.stats(tick).value_or(dca::RtLeafStats{});
  host.forget(tick);
  return {"dca node", s.wake.n, s.wake.p50_us, s.wake.p99_us, s.wake.p999_us, s.wake.max_us, std::to_string(s.missed)};
}

pid_t start_load(int seconds) {
  const std::string t = std::to_string(seconds) + "s";
  std::vector<std::string> argv_s = {"stress-ng", "--cpu", "2", "--vm", "1", "--timeout", t, "--quiet"};
  std::vector<char*> argv;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  if (posix_spawnp(&pid, "stress-ng", nullptr, nullptr, argv.data(), environ) != 0) return -1;
  return pid;
}

void print(const char* condition, const Row& r) {
  std::printf("%-6s %-10s %8llu %8.1f %8.1f %9.1f %9.1f %8s\n", condition, r.tool.c_str(),
              static_cast<unsigned long long>(r.n), r.p50, r.p99, r.p999, r.max, r.overruns.c_str());
  std::fflush(stdout);
}

void run_condition(const char* condition, const Options& o, bool cyclictest) {
  if (cyclictest) print(condition, run_cyclictest(o));
  print(condition, run_dca(o));
  print(condition, run_node(o));
}

bool parse(std::span<char* const> args, Options& o) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string a = args[i];
    const bool more = i + 1 < args.size();
    if (a == "rt" && i == 0) continue;
    if (a == "--no-load") o.load = false;
    else if (a == "--seconds" && more) o.seconds = std::atoi(args[++i]);
    else if (a == "--priority" && more) o.priority = std::atoi(args[++i]);
    else if (a == "--cpu" && more) o.cpu = std::atoi(args[++i]);
    else return false;
  }
  return !args.empty() && std::string(args[0]) == "rt" && o.seconds > 0;
}

int bench_main(std::span<char* const> args) {
  Options o;
  if (!parse(args, o)) {
    std::fprintf(stderr, "usage: dca bench rt [--seconds S] [--priority P] [--cpu C] [--no-load]\n");
    return 2;
  }
  if (o.cpu < 0) o.cpu = static_cast<int>(std::thread::hardware_concurrency()) - 1;
  if (const auto e = dca::rt::check(config(o)); !e.empty()) {
    std::fprintf(stderr, "dca bench rt: %s\n", e.c_str());
    return 2;
  }
  const bool ct = installed("cyclictest");
  if (!ct) std::fprintf(stderr, "dca bench rt: cyclictest not installed (Debian: rt-tests): dca alone\n");
  const auto w = dca::rt::warning(config(o), dca::rt::setup_process(config(o)));
  if (!w.empty()) std::fprintf(stderr, "%s\n", w.c_str());
  const std::string sched = o.priority ? "SCHED_FIFO " + std::to_string(o.priority) : "the default scheduler";
  std::printf("1 kHz wake latency, %d s each, %s, cpu %d (us)\n", o.seconds, sched.c_str(), o.cpu);
  std::printf("%-6s %-10s %8s %8s %8s %9s %9s %8s\n", "load", "tool", "n", "p50", "p99", "p99.9", "max", "overruns");
  run_condition("idle", o, ct);
  if (!o.load) return 0;
  if (!installed("stress-ng")) {
    std::fprintf(stderr, "dca bench rt: stress-ng not installed: no run under load\n");
    return 0;
  }
  const pid_t load = start_load(o.seconds * (ct ? 3 : 2) + 2);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // the load's workers are up
  run_condition("load", o, ct);
  if (load > 0) {
    kill(load, SIGTERM);
    waitpid(load, nullptr, 0);
  }
  return 0;
}

}  // namespace

DCA_SUBCOMMAND("bench", "benchmarks: rt (the real-time thread against cyclictest, idle and under load)",
               "dca bench rt [--seconds S] [--priority P] [--cpu C] [--no-load]", bench_main);

}  // namespace dca::cli::cmd_bench
