// Spawn-to-ready (BENCHMARKS.md format): time from a `spawn` request to a `dca node` being ready (registered:
// the waiting `lookup` answers), for a built-in type (Constant) and for a controller package's type (the door
// package's AddVelocity: the node loads door.dca.so first), beside the time from a `spawn` of /bin/true to its
// exit event. One local `dca daemon`, alternated A P B A P B.
// Usage: bench_node_spawn [SPAWNS_PER_ROUND]   (default 20; 2 rounds of each)
// host/loop.h comes first: it includes Asio with GCC 12's false positives silenced (the one place).
#include "host/loop.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "host/net/auth.h"
#include "host/net/channel.h"
#include "tests/bench/bench_util.h"

using Clock = std::chrono::steady_clock;
using dca::wire::Message;
using dca::wire::Value;

namespace {

void print(const char* bench, const char* variant, std::vector<double>& v) { dca::bench::result(bench, variant, v); }

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::max(1, std::atoi(argv[1])) : 20;
  const std::string dir = std::filesystem::temp_directory_path() / ("dca-bench-spawn-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string key_file = dir + "/key";
  std::string error;
  auto key = dca::auth::load_or_create_key(key_file, &error);
  if (!key) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return 1;
  }
  // The daemon, its address read from its first line.
  int out[2];
  if (::pipe(out) != 0) return 1;
  const pid_t daemon = ::fork();
  if (daemon == 0) {
    ::dup2(out[1], 1);
    ::execl(DCA_EXE, DCA_EXE, "daemon", "--host", "bench", "--key", key_file.c_str(), "--allow", "/bin/true",
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  ::close(out[1]);
  std::string line;
  char c;
  while (::read(out[0], &c, 1) == 1 && c != '\n') line += c;
  const auto at = line.rfind(' ');
  if (line.find("listening on") == std::string::npos || at == std::string::npos) {
    std::fprintf(stderr, "daemon said: %s\n", line.c_str());
    return 1;
  }
  const std::string addr = line.substr(at + 1);

  dca::Loop loop;
  dca::Channel::Ptr ch;
  dca::Channel::connect(loop.io(), *dca::Address::parse(addr), dca::ChannelOptions{*key},
                        [&](dca::Channel::Ptr p, const std::string& e) {
                          ch = p;
                          error = e;
                        });
  loop.run_until([&] { return ch || !error.empty(); }, std::chrono::seconds(10));
  if (!ch) {
    std::fprintf(stderr, "connect: %s\n", error.c_str());
    return 1;
  }
  std::optional<Message> exit_event;
  ch->on_message([&](const Message& m) {
    if (m.type == "exit") exit_event = m;
  });
  auto call = [&](Message m) {
    std::optional<dca::Response> r;
    ch->request(std::move(m), std::chrono::seconds(10), [&](dca::Response x) { r = std::move(x); });
    loop.run_until([&] { return r.has_value(); }, std::chrono::seconds(15));
    return r.value_or(dca::Response{});
  };

  std::vector<double> node_us, package_us, true_us;
  int k = 0;
  for (int round = 0; round < 2; ++round) {
    std::fprintf(stderr, "spawn round %d\n", round + 1);
    for (int i = 0; i < n; ++i) {
      // A: dca node (built-in type), P: dca node (a package's type), each until ready, then told to exit.
      for (int variant = 0; variant < 2; ++variant) {
        const std::string name = "/bench/n" + std::to_string(k++);
        Value::Array cmd{"dca", "node", "--type", "Constant", "--name", name, "--daemon", addr, "--key", key_file,
                          "--", "0", "1"};
        if (variant == 1)
          cmd = {"dca", "node", "--type", "AddVelocity", "--name", name, "--daemon", addr, "--key", key_file,
                  "--package", "door"};
        exit_event.reset();
        const auto t0 = Clock::now();
        std::optional<dca::Response> looked;
        ch->request({"lookup", 0, Value::map().set("name", name).set("wait_ms", 10000)}, std::chrono::seconds(12),
                    [&](dca::Response x) { looked = std::move(x); });
        const auto s = call({"spawn", 0, Value::map().set("argv", cmd).set("name", name)});
        loop.run_until([&] { return looked.has_value(); }, std::chrono::seconds(15));
        const auto t1 = Clock::now();
        if (!s.ok() || !looked || !looked->ok()) {
          std::fprintf(stderr, "node %s: %s %s\n", name.c_str(), s.error.c_str(), looked ? looked->error.c_str() : "no lookup");
          continue;
        }
        (variant == 0 ? node_us : package_us).push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
        call({"kill", 0, Value::map().set("child", s.message.payload["child"]).set("signal", "SIGTERM")});
        loop.run_until([&] { return exit_event.has_value(); }, std::chrono::seconds(10));
      }
      // B: /bin/true until its exit event.
      exit_event.reset();
      const auto t2 = Clock::now();
      const auto st = call({"spawn", 0, Value::map().set("argv", Value::Array{"/bin/true"})});
      loop.run_until([&] { return exit_event.has_value(); }, std::chrono::seconds(10));
      const auto t3 = Clock::now();
      if (st.ok() && exit_event) true_us.push_back(std::chrono::duration<double, std::micro>(t3 - t2).count());
    }
  }
  print("dca_spawn_to_ready", "node_Constant", node_us);
  print("dca_spawn_to_ready", "node_package_door_AddVelocity", package_us);
  print("raw_spawn_bin_true", "to_exit_event", true_us);
  ch->close();
  ::kill(daemon, SIGTERM);
  ::waitpid(daemon, nullptr, 0);
  std::filesystem::remove_all(dir);
  return 0;
}
