// pty_arm: a simulated six-joint arm on a pseudo-terminal, the device examples/pty_driver's SerialArm drives
// (docs/drivers.md, "The example's line protocol").
//   pty_arm [OPTIONS]                  prints the serial port's path, runs until SIGINT or SIGTERM
//   pty_arm [OPTIONS] -- CMD ARGS...   runs CMD with every "@PTY@" in ARGS replaced by the path, and exits with
//                                      its status when it ends
// Each joint follows its last command through a first-order lag of time constant tau (default 0.05 s): a position
// target, or a velocity target (the position integrates the velocity); it starts where worlds/ur10/ur10.urdf starts
// it and stays within its limits. A velocity target not refreshed for 0.25 s becomes 0 (the arm's own watchdog).
// It steps every 2 ms and sends a state line every 10 ms, in wall-clock time. Options:
//   --tau S          the lag's time constant (s)
//   --garble N       every Nth state line goes out with a byte changed, and after it a line too long for the
//                    protocol (what a noisy line does)
//   --hangup-after N the arm closes its side of the line once it has taken N command lines (a cable pulled
//                    while the arm moves), and goes on waiting for CMD
#include <fcntl.h>
#include <poll.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

#include "../arm.h"
#include "../protocol.h"

namespace {

using namespace pty_driver;

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int sig) { g_stop = sig; }

double mono() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

struct Options {
  double tau = 0.05;
  long garble = 0;
  long hangup_after = -1;
  std::vector<std::string> command;
};

bool parse(int argc, char** argv, Options* o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--" && i + 1 < argc) {
      for (int k = i + 1; k < argc; ++k) o->command.emplace_back(argv[k]);
      return true;
    }
    if (i + 1 >= argc) return false;
    char* end = nullptr;
    if (a == "--tau") o->tau = std::strtod(argv[++i], &end);
    else if (a == "--garble") o->garble = std::strtol(argv[++i], &end, 10);
    else if (a == "--hangup-after") o->hangup_after = std::strtol(argv[++i], &end, 10);
    else return false;
    if (*end != '\0' || !(o->tau > 0) || o->garble < 0) return false;
  }
  return true;
}

// The arm: per joint its position, velocity, effort and command.
struct Arm {
  std::array<double, kJoints> q{}, qd{}, effort{}, target{};
  std::array<char, kJoints> mode{};  // 'P', 'V'; 'P' at the start position
  std::array<double, kJoints> at{};  // when each velocity target came
  Arm() {
    for (std::size_t j = 0; j < kJoints; ++j) q[j] = target[j] = kArm[j].start, mode[j] = 'P';
  }
  void command(const Command& c, double now) {
    mode[c.joint] = c.mode;
    target[c.joint] = c.value;
    at[c.joint] = now;
  }
  void step(double dt, double tau, double now) {
    const double a = 1 - std::exp(-dt / tau);
    for (std::size_t j = 0; j < kJoints; ++j) {
      const double qd0 = qd[j];
      if (mode[j] == 'V' && now - at[j] > 0.25) target[j] = 0;
      if (mode[j] == 'P') {
        const double q1 = q[j] + a * (target[j] - q[j]);
        qd[j] = (q1 - q[j]) / dt;
        q[j] = q1;
      } else {
        qd[j] += a * (target[j] - qd[j]);
        q[j] += qd[j] * dt;
      }
      if (q[j] < kArm[j].lower || q[j] > kArm[j].upper) {  // the hard stop
        q[j] = std::clamp(q[j], kArm[j].lower, kArm[j].upper);
        qd[j] = 0;
      }
      effort[j] = (qd[j] - qd0) / dt;  // a unit inertia's torque
    }
  }
};

// Opens the pty: the master (ours) and its slave's path. The slave is kept open here too, raw, so that the
// driver's opening and closing it never hangs the line up. --> master fd, or -1 with a message
int open_pty(std::string* path, int* slave) {
  const int m = posix_openpt(O_RDWR | O_NOCTTY);
  std::array<char, 128> name{};
  if (m < 0 || grantpt(m) != 0 || unlockpt(m) != 0 || ptsname_r(m, name.data(), name.size()) != 0) {
    std::fprintf(stderr, "pty_arm: cannot open a pseudo-terminal: %s\n", std::strerror(errno));
    return -1;
  }
  fcntl(m, F_SETFD, FD_CLOEXEC);
  fcntl(m, F_SETFL, fcntl(m, F_GETFL) | O_NONBLOCK);
  *path = name.data();
  *slave = open(name.data(), O_RDWR | O_NOCTTY | O_CLOEXEC);
  termios t{};
  if (*slave >= 0 && tcgetattr(*slave, &t) == 0) {
    cfmakeraw(&t);
    tcsetattr(*slave, TCSANOW, &t);
  }
  return m;
}

// Starts the command with @PTY@ replaced; it dies with us. --> pid | -1
pid_t start(const std::vector<std::string>& command, const std::string& path) {
  std::vector<std::string> args = command;
  for (auto& a : args)
    for (std::size_t at; (at = a.find("@PTY@")) != std::string::npos;) a.replace(at, 5, path);
  const pid_t pid = fork();
  if (pid != 0) return pid;
  prctl(PR_SET_PDEATHSIG, SIGTERM);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  execvp(argv[0], argv.data());
  std::fprintf(stderr, "pty_arm: cannot run %s: %s\n", argv[0], std::strerror(errno));
  _exit(127);
}

// One state line to the master; every `garble`th changed, and followed by an overlong line.
void send_state(int m, const Arm& arm, double t, const Options& o, long* sent) {
  State s;
  s.t_ms = static_cast<std::int64_t>(t * 1000);
  s.q = arm.q, s.qd = arm.qd, s.effort = arm.effort;
  std::array<char, kMaxLine + 1> line;
  const std::size_t n = format_state(s, line.data(), line.size());
  if (n == 0) return;
  ++*sent;
  const bool garble = o.garble > 0 && *sent % o.garble == 0;
  if (garble) line[n / 2] = static_cast<char>(line[n / 2] ^ 0x21);
  (void)!write(m, line.data(), n);  // a full line or nothing: a reader that does not keep up loses states
  if (!garble) return;
  std::string junk(kMaxLine + 40, 'x');
  junk += '\n';
  (void)!write(m, junk.data(), junk.size());
}

// The loop: commands in, a step every 2 ms, a state every 10 ms, until a signal or the command's end. With
// --hangup-after, the line (m, and the slave kept open) closed after that many commands, then only the command
// waited for.
int run(int m, int slave, const Options& o, pid_t child) {
  Arm arm;
  LineReader reader;
  const double t0 = mono(), dt = 0.002;
  double next = t0 + dt;
  long steps = 0, sent = 0, bad = 0, taken = 0;
  std::array<char, 4096> buf;
  while (!g_stop) {
    int status = 0;
    if (child > 0 && waitpid(child, &status, WNOHANG) == child) {
      std::fprintf(stderr, "pty_arm: %ld command lines refused\n", bad);
      return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    }
    if (o.hangup_after >= 0 && m >= 0 && taken >= o.hangup_after) {
      close(m), close(slave);
      m = slave = -1;
      std::fprintf(stderr, "pty_arm: hung up\n");
    }
    pollfd p{m, POLLIN, 0};  // (m < 0: poll only waits)
    const int wait_ms = std::max(0, static_cast<int>(std::ceil((next - mono()) * 1000)));
    if (poll(&p, 1, wait_ms) > 0 && (p.revents & POLLIN)) {
      const ssize_t n = read(m, buf.data(), buf.size());
      const double now = mono() - t0;
      if (n > 0)
        reader.feed(buf.data(), static_cast<std::size_t>(n), [&](std::string_view line) {
          Command c;
          if (parse_command(line, &c) == LineError::none) arm.command(c, now), ++taken;
          else ++bad;
        });
    }
    for (; mono() >= next; next += dt) {
      arm.step(dt, o.tau, next - t0);
      if (++steps % 5 == 0 && m >= 0) send_state(m, arm, next - t0, o, &sent);
    }
  }
  if (child > 0) kill(child, SIGTERM), waitpid(child, nullptr, 0);
  if (m >= 0) close(m), close(slave);
  return 128 + g_stop;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, &o)) {
    std::fprintf(stderr, "usage: pty_arm [--tau S] [--garble N] [--hangup-after N] [-- COMMAND ARGS...]\n");
    return 2;
  }
  prctl(PR_SET_PDEATHSIG, SIGTERM);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::string path;
  int slave = -1;
  const int m = open_pty(&path, &slave);
  if (m < 0) return 1;
  std::printf("pty_arm: %s\n", path.c_str());
  std::fflush(stdout);
  pid_t child = -1;
  if (!o.command.empty() && (child = start(o.command, path)) < 0) {
    std::fprintf(stderr, "pty_arm: fork: %s\n", std::strerror(errno));
    return 1;
  }
  return run(m, slave, o, child);
}
