// Bounded resources before and after authentication, tried from outside as an attacker would:
//   - 100 connections that each announce a ~16 MiB frame and send a few bytes raise a daemon's control port (in
//     its handshake) and a data port by less than 16 MiB in all (peak RSS, VmHWM). Before, each connection's read
//     buffer grew at once to the declared length: +1.6 GB;
//   - a daemon at `ulimit -n 256` (soft and hard) under 400 idle connections stays below 10 % CPU and writes fewer
//     than 100 log lines a second, then serves a client once the connections are gone. Before, accept failed
//     with EMFILE in a loop: 100 % CPU and ~0.5 M log lines a second.
// Every wait is for an event (a line, a closed socket, a count in /proc) with a deadline.
#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "host/net/auth.h"
#include "host/net/channel.h"
#include "host/net/endpoint.h"
#include "host/spawn.h"
#include "tests/support/run_until.h"
#include "tests/support/temp_dir.h"

namespace {

using namespace std::chrono_literals;

std::string read_file(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// A field of /proc/PID/status in kB ("VmRSS", "VmHWM"); -1 when absent.
long status_kb(pid_t pid, const std::string& field) {
  std::istringstream in(read_file("/proc/" + std::to_string(pid) + "/status"));
  for (std::string line; std::getline(in, line);)
    if (line.rfind(field + ":", 0) == 0) return std::stol(line.substr(field.size() + 1));
  return -1;
}

// utime + stime of PID, in clock ticks.
long cpu_ticks(pid_t pid) {
  const std::string st = read_file("/proc/" + std::to_string(pid) + "/stat");
  std::istringstream in(st.substr(st.rfind(')') + 2));
  std::string f;
  long utime = 0, stime = 0;
  for (int i = 3; i <= 15 && in >> f; ++i) {
    if (i == 14) utime = std::stol(f);
    if (i == 15) stime = std::stol(f);
  }
  return utime + stime;
}

std::size_t open_fds(pid_t pid) {
  std::error_code ec;
  std::size_t n = 0;
  for (std::filesystem::directory_iterator it("/proc/" + std::to_string(pid) + "/fd", ec), end; !ec && it != end;
       it.increment(ec))
    ++n;
  return n;
}

bool wait_for(const std::function<bool()>& pred, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(5ms);  // polling /proc or a file: the event has no descriptor to wait on
  }
  return true;
}

// A TCP connection to 127.0.0.1:port, blocking connect; -1 when it fails.
int connect_to(std::uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (fd >= 0 && ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0) return fd;
  if (fd >= 0) ::close(fd);
  return -1;
}

// Sends a length prefix of `announced` bytes and a few bytes of its body.
void announce(int fd, std::uint32_t announced) {
  const std::uint32_t be = htonl(announced);
  char frame[16] = {};
  std::memcpy(frame, &be, 4);
  std::memset(frame + 4, 0x81, sizeof frame - 4);
  ASSERT_EQ(::send(fd, frame, sizeof frame, MSG_NOSIGNAL), static_cast<ssize_t>(sizeof frame));
}

// True once the peer closed `fd` (EOF or reset), reading away what it sent first (its error notice).
bool closed_by_peer(int fd, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left <= 0ms) return false;
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) return false;
    char buf[512];
    if (::recv(fd, buf, sizeof buf, 0) <= 0) return true;
  }
}

// A `dca daemon` process (optionally under `prlimit --nofile=N:N`), its output in a file.
class Daemon {
 public:
  Daemon(const std::string& dir, int nofile = 0) : log_(dir + "/daemon.log") {
    std::string error;
    const std::string key = dir + "/key";
    EXPECT_TRUE(dca::auth::load_or_create_key(key, &error)) << error;
    std::vector<std::string> argv;
    if (nofile > 0) argv = {"/usr/bin/prlimit", "--nofile=" + std::to_string(nofile) + ":" + std::to_string(nofile)};
    for (const char* a : {DCA_TEST_EXE, "daemon", "--host", "bounds", "--state-dir", "none", "--listen", "127.0.0.1:0"})
      argv.emplace_back(a);
    argv.insert(argv.end(), {"--key", key});
    dca::SpawnOptions o;
    o.stdout_path = log_;
    auto pid = dca::spawn_process(argv[0], argv, o, &error);
    EXPECT_TRUE(pid) << error;
    pid_ = pid.value_or(0);
    std::string text;
    EXPECT_TRUE(wait_for([&] { return (text = read_file(log_)).find(" listening on 127.0.0.1:") != std::string::npos; }, 20s))
        << text;
    const auto at = text.find(" listening on 127.0.0.1:");
    if (at != std::string::npos) port_ = static_cast<std::uint16_t>(std::stoi(text.substr(at + 24)));
    key_ = dca::auth::load_key(key, &error).value_or("");
  }
  ~Daemon() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    int st = 0;
    ::waitpid(pid_, &st, 0);
  }
  pid_t pid() const { return pid_; }
  std::uint16_t port() const { return port_; }
  const dca::auth::Key& key() const { return key_; }
  std::size_t log_lines() const {
    const std::string t = read_file(log_);
    return static_cast<std::size_t>(std::count(t.begin(), t.end(), '\n'));
  }

 private:
  std::string log_;
  pid_t pid_ = 0;
  std::uint16_t port_ = 0;
  dca::auth::Key key_;
};

TEST(Bounds, AnnouncedFramesCostADaemonInItsHandshakeNothing) {
  dca::test::TempDir dir("bounds");
  Daemon d(dir.path());
  ASSERT_GT(d.port(), 0);
  const long before = status_kb(d.pid(), "VmHWM");
  std::vector<int> fds;
  for (int i = 0; i < 100; ++i) {
    fds.push_back(connect_to(d.port()));
    ASSERT_GE(fds.back(), 0);
    announce(fds.back(), (16u << 20) - 16);
  }
  for (int fd : fds) {
    EXPECT_TRUE(closed_by_peer(fd, 10s)) << "the daemon did not refuse an oversize frame in the handshake";
    ::close(fd);
  }
  const long grew = status_kb(d.pid(), "VmHWM") - before;
  EXPECT_LT(grew, 16 * 1024) << "peak RSS grew by " << grew << " kB for 100 announced 16 MiB frames";
}

// An Endpoint listening in a child process; the child writes its bytes_received to `out` as they change.
pid_t endpoint_child(int out_fd, const std::string& uds) {
  const pid_t pid = ::fork();
  if (pid != 0) return pid;
  dca::Loop loop;
  dca::EndpointOptions eo;
  eo.key = "bounds-test-key-0123456789abcdef";
  dca::Endpoint ep(loop.io(), "h", eo);
  ep.listen(uds, "127.0.0.1:0");
  const std::string addr = ep.location().data_tcp;
  (void)!::write(out_fd, (addr + "\n").data(), addr.size() + 1);
  std::uint64_t said = 0;
  boost::asio::steady_timer t(loop.io());
  std::function<void()> tick = [&] {
    if (ep.bytes_received() != said) {
      said = ep.bytes_received();
      const std::string line = std::to_string(said) + "\n";
      (void)!::write(out_fd, line.data(), line.size());
    }
    t.expires_after(5ms);
    t.async_wait([&](const boost::system::error_code&) { tick(); });
  };
  tick();
  loop.run();
  ::_exit(0);
}

TEST(Bounds, AnnouncedFramesCostADataPortOnlyWhatArrives) {
  int p[2];
  ASSERT_EQ(::pipe(p), 0);
  const std::string uds = dca::test::temp_socket("bounds", "ep");
  const pid_t child = endpoint_child(p[1], uds);
  ::close(p[1]);
  std::string got;
  const auto read_line = [&] {
    for (;;) {
      if (const auto nl = got.find('\n'); nl != std::string::npos) {
        std::string line = got.substr(0, nl);
        got.erase(0, nl + 1);
        return line;
      }
      pollfd pf{p[0], POLLIN, 0};
      if (::poll(&pf, 1, 10000) <= 0) return std::string();
      char buf[256];
      const ssize_t n = ::read(p[0], buf, sizeof buf);
      if (n <= 0) return std::string();
      got.append(buf, static_cast<std::size_t>(n));
    }
  };
  const std::string addr = read_line();
  ASSERT_NE(addr.find(':'), std::string::npos) << addr;
  const auto port = static_cast<std::uint16_t>(std::stoi(addr.substr(addr.rfind(':') + 1)));
  const long before = status_kb(child, "VmHWM");
  std::vector<int> fds;
  for (int i = 0; i < 100; ++i) {
    fds.push_back(connect_to(port));
    ASSERT_GE(fds.back(), 0);
    announce(fds.back(), (16u << 20) - 16);
  }
  // every byte has been read by the child once it says so
  std::string line;
  while (!(line = read_line()).empty() && std::stoull(line) < 100u * 16u) {}
  EXPECT_FALSE(line.empty()) << "the data port did not read the 100 announcements";
  const long grew = status_kb(child, "VmHWM") - before;
  for (int fd : fds) ::close(fd);
  ::kill(child, SIGKILL);
  int st = 0;
  ::waitpid(child, &st, 0);
  ::unlink(uds.c_str());  // the killed child's socket
  ::close(p[0]);
  EXPECT_LT(grew, 16 * 1024) << "peak RSS grew by " << grew << " kB for 100 announced 16 MiB frames";
}

TEST(Bounds, ADaemonAtItsDescriptorLimitBacksOffAndServesAgain) {
  dca::test::TempDir dir("bounds");
  Daemon d(dir.path(), 256);
  ASSERT_GT(d.port(), 0);
  std::vector<int> fds;
  for (int i = 0; i < 400; ++i) {
    const int fd = connect_to(d.port());  // loopback: the kernel completes it into the listen backlog
    ASSERT_GE(fd, 0) << "connection " << i;
    fds.push_back(fd);
  }
  ASSERT_TRUE(wait_for([&] { return open_fds(d.pid()) >= 250; }, 10s)) << open_fds(d.pid()) << " descriptors";
  // two seconds at the limit, with ~150 connections still waiting in the backlog
  const long ticks0 = cpu_ticks(d.pid());
  const std::size_t lines0 = d.log_lines();
  const auto t0 = std::chrono::steady_clock::now();
  std::this_thread::sleep_for(2s);  // the measurement window (the bound is on CPU and lines over it)
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu = static_cast<double>(cpu_ticks(d.pid()) - ticks0) / static_cast<double>(::sysconf(_SC_CLK_TCK)) / secs;
  const double lines = static_cast<double>(d.log_lines() - lines0) / secs;
  EXPECT_LT(cpu, 0.10) << "CPU at the descriptor limit";
  EXPECT_LT(lines, 100.0) << "log lines a second at the descriptor limit";
  for (int fd : fds) ::close(fd);
  // descriptors free up (the daemon has seen the closes): a client is served
  EXPECT_TRUE(wait_for([&] { return open_fds(d.pid()) < 64; }, 20s)) << open_fds(d.pid()) << " descriptors";
  dca::Loop loop;
  dca::ChannelOptions o{d.key()};
  o.handshake_timeout = 10s;
  std::string error = "no answer";
  bool done = false;
  dca::Channel::connect(loop.io(), *dca::Address::parse("127.0.0.1:" + std::to_string(d.port())), o,
                        [&](dca::Channel::Ptr ch, const std::string& err) {
                          error = ch ? "" : err;
                          done = true;
                          if (ch) ch->close("done");
                        });
  EXPECT_TRUE(dca::test::run_until(loop.io(), [&] { return done; }, 20s));
  EXPECT_EQ(error, "") << "a client once the descriptors are free";
}

}  // namespace
