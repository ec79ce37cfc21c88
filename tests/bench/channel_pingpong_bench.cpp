// Round-trip latency of a 64-byte request/reply over a dca channel (authenticated, framed, msgpack) beside a raw
// Boost.Asio ping-pong of 64 bytes over the same transport, in the same run: two processes (fork), Unix socket
// and loopback TCP, each unpinned, both on CPU 0 (_cpu0-0) and one per CPU (_cpu0-1). Blocks of dca and raw
// round trips alternate (A B A B ...). Prints RESULT lines (BENCHMARKS.md); progress on stderr.
//   bench_channel_pingpong [round_trips_per_block] [blocks]
#include <sched.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include "host/loop.h"  // first: Asio with GCC 12's false positive silenced
#include <algorithm>
#include <array>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/local/stream_protocol.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "host/net/channel.h"
#include "tests/bench/bench_util.h"
#include "tests/support/channel_pair.h"

namespace {

namespace asio = boost::asio;
using Clock = std::chrono::steady_clock;
using namespace dca::test;  // Address, Channel, ..., kKey
constexpr std::size_t kSize = 64;

void pin(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (cpu < 0) {
    for (int c = 0; c < CPU_SETSIZE; ++c) CPU_SET(c, &set);
  } else {
    CPU_SET(cpu, &set);
  }
  sched_setaffinity(0, sizeof set, &set);
}

// --- the server process: a dca echo listener and a raw echo acceptor --------------------------------------------

template <typename Socket>
void raw_echo(std::shared_ptr<Socket> s, std::shared_ptr<std::array<char, kSize>> buf) {
  asio::async_read(*s, asio::buffer(*buf), [s, buf](const boost::system::error_code& ec, std::size_t) {
    if (ec) return;
    asio::async_write(*s, asio::buffer(*buf), [s, buf](const boost::system::error_code& wec, std::size_t) {
      if (!wec) raw_echo(s, buf);
    });
  });
}

template <typename Acceptor, typename Socket>
void raw_accept(asio::io_context& io, Acceptor& a) {
  auto s = std::make_shared<Socket>(io);
  a.async_accept(*s, [&io, &a, s](const boost::system::error_code& ec) {
    if (ec) return;
    if constexpr (std::is_same_v<Socket, asio::ip::tcp::socket>) s->set_option(asio::ip::tcp::no_delay(true));
    raw_echo(s, std::make_shared<std::array<char, kSize>>());
    raw_accept<Acceptor, Socket>(io, a);
  });
}

[[noreturn]] void serve(bool tcp, int cpu, int ready_fd, const std::string& uds_dir) {
  pin(cpu);
  dca::Loop loop;
  std::string error;
  const std::string dca_addr = tcp ? "127.0.0.1:0" : "unix:" + uds_dir + "/dca.sock";
  auto l = dca::Listener::listen(
      loop.io(), *Address::parse(dca_addr), ChannelOptions{kKey},
      [](Channel::Ptr ch) {
        Channel* c = ch.get();
        ch->on_message([c](const Message& m) { c->reply(m, m.payload); });
      },
      &error);
  if (!l) {
    std::fprintf(stderr, "server: %s\n", error.c_str());
    std::_Exit(1);
  }
  std::string raw_addr;
  std::unique_ptr<asio::ip::tcp::acceptor> tcp_acc;
  std::unique_ptr<asio::local::stream_protocol::acceptor> uds_acc;
  if (tcp) {
    tcp_acc = std::make_unique<asio::ip::tcp::acceptor>(loop.io(), asio::ip::tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0));
    raw_accept<asio::ip::tcp::acceptor, asio::ip::tcp::socket>(loop.io(), *tcp_acc);
    raw_addr = "127.0.0.1:" + std::to_string(tcp_acc->local_endpoint().port());
  } else {
    raw_addr = uds_dir + "/raw.sock";
    uds_acc = std::make_unique<asio::local::stream_protocol::acceptor>(loop.io(), asio::local::stream_protocol::endpoint(raw_addr));
    raw_accept<asio::local::stream_protocol::acceptor, asio::local::stream_protocol::socket>(loop.io(), *uds_acc);
  }
  const std::string line = l->address().str() + " " + raw_addr + "\n";
  if (::write(ready_fd, line.data(), line.size()) < 0) std::_Exit(1);
  ::close(ready_fd);
  loop.on_signals({SIGTERM}, [&](int) { loop.stop(); });
  loop.run();
  std::_Exit(0);
}

// --- the client: timed round trips ------------------------------------------------------------------------------

struct Stats {
  std::vector<double> us;
};

void dca_block(dca::Loop& loop, Channel& ch, int n, Stats* out) {
  // A payload that makes the request frame 64 bytes: [type, id, {d = <bytes>}].
  Message m{"p", 0, Value::map().set("d", std::string(kSize - 16, 'x'))};
  int done = 0;
  Clock::time_point t0;
  std::function<void()> next = [&] {
    t0 = Clock::now();
    ch.request(m, std::chrono::seconds(10), [&](dca::Response r) {
      const auto dt = std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
      if (!r.ok()) {
        std::fprintf(stderr, "request failed: %s\n", r.error.c_str());
        std::exit(1);
      }
      if (out != nullptr) out->us.push_back(dt);
      if (++done < n) next();
    });
  };
  next();
  loop.run_until([&] { return done >= n; }, std::chrono::seconds(120));
}

template <typename Socket>
void raw_block(dca::Loop& loop, Socket& s, int n, Stats* out) {
  std::array<char, kSize> buf{};
  int done = 0;
  Clock::time_point t0;
  std::function<void()> next = [&] {
    t0 = Clock::now();
    asio::async_write(s, asio::buffer(buf), [&](const boost::system::error_code& ec, std::size_t) {
      if (ec) std::exit(1);
      asio::async_read(s, asio::buffer(buf), [&](const boost::system::error_code& rec, std::size_t) {
        if (rec) std::exit(1);
        const auto dt = std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
        if (out != nullptr) out->us.push_back(dt);
        if (++done < n) next();
      });
    });
  };
  next();
  loop.run_until([&] { return done >= n; }, std::chrono::seconds(120));
}

void print(const char* bench, const std::string& variant, Stats& s, const std::string& extra = "") {
  dca::bench::result(bench, variant, s.us, extra);
}

void run_variant(bool tcp, const char* placement, int server_cpu, int client_cpu, int n, int blocks) {
  std::string tmpl = dca::bench::temp_path("dca_bench") + "_XXXXXX";
  const std::string dir = ::mkdtemp(tmpl.data());
  int fds[2];
  if (::pipe(fds) != 0) std::exit(1);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    serve(tcp, server_cpu, fds[1], dir);
  }
  ::close(fds[1]);
  pin(client_cpu);
  std::string line;
  char c;
  while (::read(fds[0], &c, 1) == 1 && c != '\n') line += c;
  ::close(fds[0]);
  const auto sp = line.find(' ');
  if (sp == std::string::npos) {
    std::fprintf(stderr, "server did not start\n");
    std::exit(1);
  }
  const std::string dca_addr = line.substr(0, sp), raw_addr = line.substr(sp + 1);

  dca::Loop loop;
  Channel::Ptr ch;
  Channel::connect(loop.io(), *Address::parse(dca_addr), ChannelOptions{kKey},
                   [&](Channel::Ptr got, const std::string& e) {
                     if (!got) std::fprintf(stderr, "connect: %s\n", e.c_str());
                     ch = got;
                   });
  loop.run_until([&] { return ch != nullptr; }, std::chrono::seconds(10));
  if (!ch) std::exit(1);

  Stats dca_stats, raw_stats;
  const std::string transport = tcp ? "tcp" : "uds";
  const std::string variant = std::to_string(kSize) + "B_" + transport + placement;
  std::fprintf(stderr, "variant %s: %d blocks of %d round trips each\n", variant.c_str(), blocks, n);
  const auto run_raw = [&](auto& sock) {
    dca_block(loop, *ch, n / 10, nullptr);  // warm-up
    raw_block(loop, sock, n / 10, nullptr);
    for (int b = 0; b < blocks; ++b) {
      dca_block(loop, *ch, n, &dca_stats);
      raw_block(loop, sock, n, &raw_stats);
    }
  };
  if (tcp) {
    asio::ip::tcp::socket s(loop.io());
    const auto a = *Address::parse(raw_addr);
    s.connect({asio::ip::make_address(a.host), a.port});
    s.set_option(asio::ip::tcp::no_delay(true));
    run_raw(s);
  } else {
    asio::local::stream_protocol::socket s(loop.io());
    s.connect(asio::local::stream_protocol::endpoint(raw_addr));
    run_raw(s);
  }
  ch->close();
  ::kill(pid, SIGTERM);
  int st = 0;
  ::waitpid(pid, &st, 0);
  pin(-1);
  std::sort(dca_stats.us.begin(), dca_stats.us.end());
  std::sort(raw_stats.us.begin(), raw_stats.us.end());
  char ratio[64];
  std::snprintf(ratio, sizeof ratio, " ratio_p50=%.2f", dca::bench::quantile(dca_stats.us, 0.5) / std::max(1e-9, dca::bench::quantile(raw_stats.us, 0.5)));
  print("dca_channel_pingpong", variant, dca_stats, ratio);
  print(tcp ? "raw_tcp_pingpong" : "raw_uds_pingpong", variant, raw_stats);
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 2000;
  const int blocks = argc > 2 ? std::atoi(argv[2]) : 4;
  std::signal(SIGPIPE, SIG_IGN);
  const int cpus = static_cast<int>(::sysconf(_SC_NPROCESSORS_ONLN));
  for (bool tcp : {false, true}) {
    run_variant(tcp, "", -1, -1, n, blocks);
    run_variant(tcp, "_cpu0-0", 0, 0, n, blocks);
    if (cpus >= 2) run_variant(tcp, "_cpu0-1", 1, 0, n, blocks);
  }
  return 0;
}
