// Data-plane benchmarks (BENCHMARKS.md format), each beside its raw baseline measured in the same run:
//   - round trip of a 64-byte sample through two controllers (a pinger and a Gain echo):
//       in-process (beside a raw function-call hand-off), two processes over a Unix socket and over loopback TCP
//       (beside a raw Boost.Asio ping-pong of 64 bytes over the same transport), placements unpinned, _cpu0-0
//       and _cpu0-1, alternated A B A B;
//   - samples/s through one Unix-socket push connection (beside raw Asio writes of the same frames).
//   - connection set-up: Endpoint::connect to the answer of the hello (connect, the cluster-key handshake, the
//     hello), over a Unix socket and TCP in one process, beside a raw connect plus one 64-byte round trip (what a
//     connection with a hello and no authentication costs), alternated A B A B. The difference is what
//     authentication adds (one more round trip and four HMAC-SHA256);
//   - a link made on a connection already open (a process's later links to another: one hello's round trip),
//     beside a raw 64-byte round trip between two processes over the same transport;
//   - on TCP, the segments sent per round trip (the `segments_per_rt` key of the pingpong lines). The two links
//     of a round trip ride one socket connection, as the raw ping-pong does, so each reply carries the
//     acknowledgement of its request.
// Usage: bench_comms [ROUND_TRIPS_PER_ROUND]   (default 2000; 2 rounds of each)
#include "host/loop.h"  // first: Asio with GCC 12's false positives silenced

#include <poll.h>
#include <sched.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include <boost/asio/generic/stream_protocol.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/local/stream_protocol.hpp>
#include <boost/asio/posix/stream_descriptor.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>

#include <dca/registry.h>
#include "host/net/endpoint.h"
#include "host/timers.h"
#include "tests/bench/bench_util.h"
#include "tests/support/run_until.h"

namespace asio = boost::asio;
using Clock = std::chrono::steady_clock;

namespace {

constexpr int kDoubles = 8;  // 64 bytes

// Every endpoint of the bench holds one cluster key: socket connections authenticate once at connect time.
dca::EndpointOptions bench_keyed() {
  dca::EndpointOptions o;
  o.key = "comms-bench-cluster-key-01234567";
  return o;
}

void pin(int cpu) {
  if (cpu < 0) return;
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  sched_setaffinity(0, sizeof set, &set);
}

struct Samples {
  std::vector<double> us;
  void add(Clock::duration d) { us.push_back(std::chrono::duration<double, std::micro>(d).count()); }
};

void print(const char* bench, const std::string& variant, Samples& s, const std::string& extra = "") {
  dca::bench::result(bench, variant, s.us, extra, 2);
}

// Runs `io` until `pred` holds, at most `timeout` (10 s by default).
bool run_until(asio::io_context& io, const std::function<bool()>& pred, std::chrono::seconds timeout = std::chrono::seconds(10)) {
  return dca::test::run_until(io, pred, timeout);
}

// --- the echo side in a child process --------------------------------------------------------------------

// dca echo: an Endpoint with a Gain(k=1) controller "/echo" that connects its Out back to the parent's "/ping".
// Protocol over `pipe_w`: writes its TCP port (int) once listening, then (once its link back is made) again.
// The parent sends its own port on `pipe_r` once its link to the echo is made, so the link back finds the
// connection the parent opened.
[[noreturn]] void dca_echo_child(bool tcp, const std::string& uds, int cpu, int pipe_w, int pipe_r) {
  pin(cpu);
  asio::io_context io;
  dca::TimerServer timers(io, dca::ClockKind::Wall);
  dca::Endpoint ep(io, tcp ? "b" : "a", bench_keyed());
  auto gain = dca::Registry::global().create("Gain", {"/echo", "b", {"1"}, &timers, nullptr});
  ep.add_component("/echo", gain->ports());
  ep.listen(uds + ".echo", "127.0.0.1:0");
  const auto loc = ep.location();
  const int port = std::stoi(loc.data_tcp.substr(loc.data_tcp.rfind(':') + 1));
  [[maybe_unused]] auto w = ::write(pipe_w, &port, sizeof port);
  // Wait for the parent's address (its TCP port), serving its connection meanwhile, then connect back.
  run_until(io, [&] {
    pollfd pfd{pipe_r, POLLIN, 0};
    return ::poll(&pfd, 1, 0) == 1;
  }, std::chrono::seconds(30));
  int parent_port = 0;
  [[maybe_unused]] auto r = ::read(pipe_r, &parent_port, sizeof parent_port);
  std::string err = "pending";
  ep.connect({"/echo", "Out", "/ping", "In", "s", dca::Mode::Push, 16},
             {"a", uds, "127.0.0.1:" + std::to_string(parent_port)}, [&](const std::string& e) { err = e; });
  run_until(io, [&] { return err != "pending"; });
  if (!err.empty()) {
    std::fprintf(stderr, "echo: %s\n", err.c_str());
    ::_exit(1);
  }
  ep.activate("s");
  gain->start({}, nullptr);
  [[maybe_unused]] auto w2 = ::write(pipe_w, &port, sizeof port);  // ready
  ep.on_event([&](const dca::CommsEvent& e) {
    if (e.kind == dca::CommsEvent::Kind::Broken) io.stop();
  });
  io.run();
  ::_exit(0);
}

// Echoes 64-byte blocks on `s` until the peer goes away (then stops `io`).
template <class Socket>
void echo_forever(asio::io_context& io, Socket& s, std::array<char, 64>& buf) {
  std::function<void()> loop = [&] {
    asio::async_read(s, asio::buffer(buf), [&](boost::system::error_code ec, std::size_t) {
      if (ec) return io.stop();
      asio::async_write(s, asio::buffer(buf), [&](boost::system::error_code ec2, std::size_t) {
        if (ec2) return io.stop();
        loop();
      });
    });
  };
  loop();
  io.run();
}

// raw echo: Asio, read 64 bytes, write them back, forever.
[[noreturn]] void raw_echo_child(bool tcp, const std::string& uds, int cpu, int pipe_w) {
  pin(cpu);
  asio::io_context io;
  std::array<char, 64> buf{};
  int port = 0;
  if (tcp) {
    asio::ip::tcp::acceptor acc(io, {asio::ip::make_address("127.0.0.1"), 0});
    port = acc.local_endpoint().port();
    [[maybe_unused]] auto w = ::write(pipe_w, &port, sizeof port);
    asio::ip::tcp::socket s = acc.accept();
    s.set_option(asio::ip::tcp::no_delay(true));
    echo_forever(io, s, buf);
  } else {
    ::unlink((uds + ".raw").c_str());
    asio::local::stream_protocol::acceptor acc(io, asio::local::stream_protocol::endpoint(uds + ".raw"));
    [[maybe_unused]] auto w = ::write(pipe_w, &port, sizeof port);
    asio::local::stream_protocol::socket s = acc.accept();
    echo_forever(io, s, buf);
  }
  ::_exit(0);
}

// --- the measuring side -----------------------------------------------------------------------------------

void dca_socket_round(bool tcp, int cpu_parent, int cpu_child, int n, Samples& out) {
  const std::string uds = dca::bench::temp_path("dca-bench");
  int up[2], down[2];
  if (::pipe(up) != 0 || ::pipe(down) != 0) return;
  const pid_t child = ::fork();
  if (child == 0) dca_echo_child(tcp, uds, cpu_child, up[1], down[0]);
  pin(cpu_parent);
  asio::io_context io;
  dca::Endpoint ep(io, "a", bench_keyed());
  dca::PortSet ping;
  auto& o = ping.add_output(dca::vectorx_port("Out"));
  auto& in = ping.add_input(dca::vectorx_port("In"));
  ep.add_component("/ping", ping);
  ep.listen(uds, "127.0.0.1:0");
  int child_port = 0;
  [[maybe_unused]] auto r1 = ::read(up[0], &child_port, sizeof child_port);
  const auto loc = ep.location();
  const int my_port = std::stoi(loc.data_tcp.substr(loc.data_tcp.rfind(':') + 1));
  std::string err = "pending";
  ep.connect({"/ping", "Out", "/echo", "In", "s", dca::Mode::Push, 16},
             {tcp ? "b" : "a", uds + ".echo", "127.0.0.1:" + std::to_string(child_port)},
             [&](const std::string& e) { err = e; });
  run_until(io, [&] { return err != "pending"; });
  [[maybe_unused]] auto w1 = ::write(down[1], &my_port, sizeof my_port);
  // The child connects back to us: keep our io_context turning until it says it is ready.
  run_until(io, [&] {
    pollfd pfd{up[0], POLLIN, 0};
    return ::poll(&pfd, 1, 0) == 1;
  });
  int ready = 0;
  [[maybe_unused]] auto r2 = ::read(up[0], &ready, sizeof ready);
  if (!err.empty()) {
    std::fprintf(stderr, "connect: %s\n", err.c_str());
  } else {
    ep.activate("s");
    Eigen::VectorXd x = Eigen::VectorXd::Constant(kDoubles, 1.0);
    bool got = false;
    in.on_sample = [&] { got = true; };
    for (int i = 0; i < n + 100; ++i) {
      got = false;
      const auto t0 = Clock::now();
      o.write(x);
      while (!got) io.run_one();
      const auto t1 = Clock::now();
      in.pop();
      if (i >= 100) out.add(t1 - t0);  // the first 100 warm up
    }
  }
  ep.remove_component("/ping");
  ::kill(child, SIGTERM);
  ::waitpid(child, nullptr, 0);
  ::unlink((uds + ".echo").c_str());  // the child's socket: it ends by _exit, its Endpoint never closes
  for (int f : {up[0], up[1], down[0], down[1]}) ::close(f);
}

void raw_socket_round(bool tcp, int cpu_parent, int cpu_child, int n, Samples& out) {
  const std::string uds = dca::bench::temp_path("dca-bench");
  int up[2];
  if (::pipe(up) != 0) return;
  const pid_t child = ::fork();
  if (child == 0) raw_echo_child(tcp, uds, cpu_child, up[1]);
  pin(cpu_parent);
  int port = 0;
  [[maybe_unused]] auto r = ::read(up[0], &port, sizeof port);
  asio::io_context io;
  auto work = asio::make_work_guard(io);  // run_one must never find the context out of work
  std::array<char, 64> buf{}, back{};
  auto measure = [&](auto& s) {
    bool got = false;
    for (int i = 0; i < n + 100; ++i) {
      got = false;
      const auto t0 = Clock::now();
      asio::async_write(s, asio::buffer(buf), [](boost::system::error_code, std::size_t) {});
      asio::async_read(s, asio::buffer(back), [&](boost::system::error_code, std::size_t) { got = true; });
      while (!got) io.run_one();
      const auto t1 = Clock::now();
      if (i >= 100) out.add(t1 - t0);
    }
  };
  if (tcp) {
    asio::ip::tcp::socket s(io);
    s.connect({asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port)});
    s.set_option(asio::ip::tcp::no_delay(true));
    measure(s);
  } else {
    asio::local::stream_protocol::socket s(io);
    s.connect(asio::local::stream_protocol::endpoint(uds + ".raw"));
    measure(s);
  }
  ::kill(child, SIGTERM);
  ::waitpid(child, nullptr, 0);
  ::unlink((uds + ".raw").c_str());
  ::close(up[0]);
  ::close(up[1]);
}

void dca_inprocess_round(int n, Samples& out) {
  asio::io_context io;
  dca::TimerServer timers(io, dca::ClockKind::Wall);
  dca::Endpoint ep(io, "a", bench_keyed());
  auto gain = dca::Registry::global().create("Gain", {"/echo", "a", {"1"}, &timers, nullptr});
  dca::PortSet ping;
  auto& o = ping.add_output(dca::vectorx_port("Out"));
  auto& in = ping.add_input(dca::vectorx_port("In"));
  ep.add_component("/ping", ping);
  ep.add_component("/echo", gain->ports());
  std::string e1 = "x", e2 = "x";
  ep.connect({"/ping", "Out", "/echo", "In", "s", dca::Mode::Push, 16}, {}, [&](const std::string& e) { e1 = e; });
  ep.connect({"/echo", "Out", "/ping", "In", "s", dca::Mode::Push, 16}, {}, [&](const std::string& e) { e2 = e; });
  ep.activate("s");
  gain->start({}, nullptr);
  Eigen::VectorXd x = Eigen::VectorXd::Constant(kDoubles, 1.0);
  Clock::time_point t1;
  in.on_sample = [&] { t1 = Clock::now(); };
  for (int i = 0; i < n + 100; ++i) {
    const auto t0 = Clock::now();
    o.write(x);
    in.pop();
    if (i >= 100) out.add(t1 - t0);
  }
  ep.remove_component("/ping");
  ep.remove_component("/echo");
}

void raw_inprocess_round(int n, Samples& out) {
  // The same hand-off done by hand: copy 64 bytes into the echo's buffer, call it, it copies them back.
  std::array<double, kDoubles> a{}, b{}, c{};
  Clock::time_point t1;
  std::function<void()> back = [&] { t1 = Clock::now(); };
  std::function<void()> echo = [&] {
    std::memcpy(c.data(), b.data(), sizeof c);
    back();
  };
  for (int i = 0; i < n + 100; ++i) {
    const auto t0 = Clock::now();
    std::memcpy(b.data(), a.data(), sizeof b);
    echo();
    if (i >= 100) out.add(t1 - t0);
  }
}

// Samples/s through one push connection over a Unix socket (receiver in a child process).
double dca_throughput(int n) {
  const std::string uds = dca::bench::temp_path("dca-bench-tp");
  int up[2];
  if (::pipe(up) != 0) return 0;
  const pid_t child = ::fork();
  if (child == 0) {
    asio::io_context io;
    dca::Endpoint ep(io, "a", bench_keyed());
    dca::PortSet sink;
    auto& in = sink.add_input(dca::vectorx_port("In"));
    ep.add_component("/sink", sink);
    ep.listen(uds, "");
    std::uint64_t got = 0;
    in.on_sample = [&] {
      in.pop();
      if (++got == static_cast<std::uint64_t>(n)) {
        [[maybe_unused]] auto w = ::write(up[1], &got, sizeof got);
      }
    };
    int ok = 1;
    [[maybe_unused]] auto w = ::write(up[1], &ok, sizeof ok);
    io.run();
    ::_exit(0);
  }
  int ok = 0;
  [[maybe_unused]] auto r = ::read(up[0], &ok, sizeof ok);
  asio::io_context io;
  dca::Endpoint ep(io, "a", bench_keyed());
  dca::PortSet src;
  auto& o = src.add_output(dca::vectorx_port("Out"));
  ep.add_component("/src", src);
  std::string err = "pending";
  ep.connect({"/src", "Out", "/sink", "In", "s", dca::Mode::Push, 64}, {"a", uds, ""}, [&](const std::string& e) { err = e; });
  run_until(io, [&] { return err != "pending"; });
  ep.activate("s");
  Eigen::VectorXd x = Eigen::VectorXd::Constant(kDoubles, 1.0);
  const auto t0 = Clock::now();
  for (int i = 0; i < n; ++i) {
    o.write(x);
    if ((i & 63) == 0) io.poll();  // let backed-up writes drain
  }
  std::uint64_t got = 0;
  // Keep the io_context turning until the receiver has every sample.
  bool done = false;
  asio::posix::stream_descriptor pd(io, ::dup(up[0]));
  pd.async_read_some(asio::buffer(&got, sizeof got), [&](boost::system::error_code, std::size_t) { done = true; });
  run_until(io, [&] { return done; }, std::chrono::seconds(30));
  const double secs = std::chrono::duration<double>(Clock::now() - t0).count();
  ep.remove_component("/src");
  ::kill(child, SIGTERM);
  ::waitpid(child, nullptr, 0);
  ::unlink(uds.c_str());  // the child's socket: SIGTERM ends it before its Endpoint closes
  ::close(up[0]);
  ::close(up[1]);
  return done ? n / secs : 0;
}

double raw_throughput(int n) {
  const std::string uds = dca::bench::temp_path("dca-bench-tpr");
  ::unlink(uds.c_str());
  int up[2];
  if (::pipe(up) != 0) return 0;
  const pid_t child = ::fork();
  if (child == 0) {
    asio::io_context io;
    asio::local::stream_protocol::acceptor acc(io, asio::local::stream_protocol::endpoint(uds));
    int ok = 1;
    [[maybe_unused]] auto w = ::write(up[1], &ok, sizeof ok);
    auto s = acc.accept();
    std::array<char, 69> frame{};  // the same 5-byte header + 64-byte body as a dca sample frame
    for (int i = 0; i < n; ++i) asio::read(s, asio::buffer(frame));
    [[maybe_unused]] auto w2 = ::write(up[1], &ok, sizeof ok);
    ::_exit(0);
  }
  int ok = 0;
  [[maybe_unused]] auto r = ::read(up[0], &ok, sizeof ok);
  asio::io_context io;
  asio::local::stream_protocol::socket s(io);
  s.connect(asio::local::stream_protocol::endpoint(uds));
  std::array<char, 69> frame{};
  const auto t0 = Clock::now();
  for (int i = 0; i < n; ++i) asio::write(s, asio::buffer(frame));
  [[maybe_unused]] auto r2 = ::read(up[0], &ok, sizeof ok);
  const double secs = std::chrono::duration<double>(Clock::now() - t0).count();
  ::waitpid(child, nullptr, 0);
  ::unlink(uds.c_str());
  ::close(up[0]);
  ::close(up[1]);
  return n / secs;
}

}  // namespace

// n connection set-ups through Endpoint::connect (connect, handshake, introduction, hello), each timed to its
// answer. Each from a fresh source endpoint (a process's first link to another: later links to it ride the
// connection and cost one hello's round trip).
void dca_connect_round(bool tcp, int n, Samples& out) {
  asio::io_context io;
  dca::Endpoint b(io, tcp ? "b" : "a", bench_keyed());
  b.listen(dca::bench::temp_path("dca-bench-setup"), "127.0.0.1:0");
  dca::PortSet dst;
  dst.add_input(dca::vectorx_port("In"));
  b.add_component("/dst", dst);
  for (int i = 0; i < n + 20; ++i) {
    {
      dca::PortSet src;
      src.add_output(dca::vectorx_port("Out"));
      dca::Endpoint a(io, "a", bench_keyed());
      a.add_component("/src", src);
      std::string err = "pending";
      const auto t0 = Clock::now();
      a.connect({"/src", "Out", "/dst", "In", "c", dca::Mode::Push, 16}, b.location(), [&](const std::string& e) { err = e; });
      run_until(io, [&] { return err != "pending"; });
      const auto t1 = Clock::now();
      if (!err.empty()) std::fprintf(stderr, "connect: %s\n", err.c_str());
      if (i >= 20) out.add(t1 - t0);  // the first 20 warm up
      a.remove_component("/src");
    }
    run_until(io, [&] { return b.accepted() == 0; });
  }
  b.remove_component("/dst");
}

// n links made over one open connection (a hello and its answer), each timed to its answer, then removed.
void dca_link_round(bool tcp, int n, Samples& out) {
  asio::io_context io;
  dca::Endpoint a(io, "a", bench_keyed()), b(io, tcp ? "b" : "a", bench_keyed());
  b.listen(dca::bench::temp_path("dca-bench-link"), "127.0.0.1:0");
  dca::PortSet src, dst;
  src.add_output(dca::vectorx_port("Out"));
  dst.add_input(dca::vectorx_port("In"));
  a.add_component("/src", src);
  b.add_component("/dst", dst);
  for (int i = 0; i < n + 20; ++i) {
    const std::string set = "l" + std::to_string(i);
    std::string err = "pending";
    const auto t0 = Clock::now();
    a.connect({"/src", "Out", "/dst", "In", set, dca::Mode::Push, 16}, b.location(), [&](const std::string& e) { err = e; });
    run_until(io, [&] { return err != "pending"; });
    const auto t1 = Clock::now();
    if (!err.empty()) std::fprintf(stderr, "link: %s\n", err.c_str());
    if (i >= 20) out.add(t1 - t0);  // the first 20 warm up (the first opens the connection)
    a.disconnect_set(set);
  }
  a.remove_component("/src");
  b.remove_component("/dst");
}

// n raw connections, each: connect, 64 bytes there and back (an unauthenticated hello and its answer).
void raw_connect_round(bool tcp, int n, Samples& out) {
  using generic = asio::generic::stream_protocol;
  asio::io_context io;
  const std::string uds = dca::bench::temp_path("dca-bench-rawsetup");
  ::unlink(uds.c_str());
  generic::endpoint at = tcp ? generic::endpoint(asio::ip::tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0))
                             : generic::endpoint(asio::local::stream_protocol::endpoint(uds));
  asio::basic_socket_acceptor<generic> acc(io, at);
  at = acc.local_endpoint();
  std::array<char, 64> buf{}, back{}, echo{};
  for (int i = 0; i < n + 20; ++i) {
    generic::socket c(io), srv(io);
    bool got = false;
    const auto t0 = Clock::now();
    acc.async_accept(srv, [&](boost::system::error_code ec) {
      if (ec) return;
      if (tcp) srv.set_option(asio::ip::tcp::no_delay(true));
      asio::async_read(srv, asio::buffer(echo), [&](boost::system::error_code e2, std::size_t) {
        if (!e2) asio::async_write(srv, asio::buffer(echo), [](boost::system::error_code, std::size_t) {});
      });
    });
    c.async_connect(at, [&](boost::system::error_code ec) {
      if (ec) return;
      if (tcp) c.set_option(asio::ip::tcp::no_delay(true));
      asio::async_write(c, asio::buffer(buf), [](boost::system::error_code, std::size_t) {});
      asio::async_read(c, asio::buffer(back), [&](boost::system::error_code, std::size_t) { got = true; });
    });
    run_until(io, [&] { return got; });
    const auto t1 = Clock::now();
    if (i >= 20) out.add(t1 - t0);
  }
  ::unlink(uds.c_str());
}

// TCP segments sent by this machine so far (/proc/net/snmp, Tcp: OutSegs).
long out_segments() {
  std::FILE* f = std::fopen("/proc/net/snmp", "r");
  if (f == nullptr) return 0;
  char line[1024];
  long v = 0;
  bool header_seen = false;
  while (std::fgets(line, sizeof line, f) != nullptr) {
    if (std::strncmp(line, "Tcp:", 4) != 0) continue;
    if (!header_seen) { header_seen = true; continue; }
    long fields[16] = {};
    std::sscanf(line + 4, "%ld %ld %ld %ld %ld %ld %ld %ld %ld %ld %ld", &fields[0], &fields[1], &fields[2], &fields[3],
                &fields[4], &fields[5], &fields[6], &fields[7], &fields[8], &fields[9], &fields[10]);
    v = fields[10];  // OutSegs
  }
  std::fclose(f);
  return v;
}

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::max(100, std::atoi(argv[1])) : 2000;
  ::signal(SIGPIPE, SIG_IGN);
  const int ncpu = static_cast<int>(::sysconf(_SC_NPROCESSORS_ONLN));
  struct Placement {
    const char* suffix;
    int parent, child;
  };
  std::vector<Placement> placements{{"", -1, -1}, {"_cpu0-0", 0, 0}};
  if (ncpu > 1) placements.push_back({"_cpu0-1", 0, 1});

  {  // in-process
    Samples d, r;
    for (int round = 0; round < 2; ++round) {
      std::fprintf(stderr, "in-process round %d\n", round + 1);
      dca_inprocess_round(n, d);
      raw_inprocess_round(n, r);
    }
    print("dca_pingpong", "64B_inprocess", d);
    print("raw_call_pingpong", "64B_inprocess", r);
  }
  for (bool tcp : {false, true}) {
    for (const auto& p : placements) {
      Samples d, r;
      long dseg = 0, rseg = 0;
      for (int round = 0; round < 2; ++round) {
        std::fprintf(stderr, "%s%s round %d\n", tcp ? "tcp" : "uds", p.suffix, round + 1);
        const long s0 = out_segments();
        dca_socket_round(tcp, p.parent, p.child, n, d);
        const long s1 = out_segments();
        raw_socket_round(tcp, p.parent, p.child, n, r);
        const long s2 = out_segments();
        dseg += s1 - s0;
        rseg += s2 - s1;
      }
      pin(-1);
      cpu_set_t all;
      CPU_ZERO(&all);
      for (int c = 0; c < ncpu; ++c) CPU_SET(c, &all);
      sched_setaffinity(0, sizeof all, &all);
      const std::string v = std::string("64B_") + (tcp ? "tcp" : "uds") + p.suffix;
      // On TCP, the segments sent per round trip (set-up and warm-up included: a few hundredths).
      const auto segments = [&](long count) {
        char f[64];
        std::snprintf(f, sizeof f, " segments_per_rt=%.2f", double(count) / (2.0 * (n + 100)));
        return tcp ? std::string(f) : std::string();
      };
      print("dca_pingpong", v, d, segments(dseg));
      print(tcp ? "raw_tcp_pingpong" : "raw_uds_pingpong", v, r, segments(rseg));
      if (!d.us.empty() && !r.us.empty())
        std::fprintf(stderr, "  ratio p50 dca/raw = %.2f\n", d.us[d.us.size() / 2] / r.us[r.us.size() / 2]);
    }
  }
  for (bool tcp : {false, true}) {  // connection set-up
    Samples d, r;
    for (int round = 0; round < 2; ++round) {
      std::fprintf(stderr, "set-up %s round %d\n", tcp ? "tcp" : "uds", round + 1);
      dca_connect_round(tcp, n / 10, d);
      raw_connect_round(tcp, n / 10, r);
    }
    const std::string v = std::string("setup_") + (tcp ? "tcp" : "uds");
    print("dca_connect", v, d);
    print("raw_connect_roundtrip", v, r);
  }
  for (bool tcp : {false, true}) {  // a link on a connection already open, beside a raw 64-byte round trip
    Samples d, r;
    for (int round = 0; round < 2; ++round) {
      std::fprintf(stderr, "link on an open connection %s round %d\n", tcp ? "tcp" : "uds", round + 1);
      dca_link_round(tcp, n / 10, d);
      raw_socket_round(tcp, -1, -1, n / 10, r);
    }
    const std::string v = std::string("link_") + (tcp ? "tcp" : "uds");
    print("dca_link", v, d);
    print(tcp ? "raw_tcp_pingpong" : "raw_uds_pingpong", v, r);
  }
  {  // throughput
    const int m = n * 50;
    double d = 0, r = 0;
    for (int round = 0; round < 2; ++round) {
      d = std::max(d, dca_throughput(m));
      r = std::max(r, raw_throughput(m));
    }
    Samples sd, sr;
    sd.us.push_back(d > 0 ? 1e6 / d : 0);
    sr.us.push_back(r > 0 ? 1e6 / r : 0);
    print("dca_samples", "64B_uds_push", sd, " samples_per_s=" + std::to_string(static_cast<long long>(d)));
    print("raw_uds_writes", "69B_uds", sr, " samples_per_s=" + std::to_string(static_cast<long long>(r)));
  }
  return 0;
}
