#include "host/exec.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <string.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <boost/asio/steady_timer.hpp>
#include <cctype>
#include <boost/asio/posix/stream_descriptor.hpp>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <utility>

#include "host/paths.h"
#include "host/spawn.h"

namespace dca {
namespace asio = boost::asio;

namespace {

std::string self_exe() {
  const std::string p = exe_path();
  return p.empty() ? std::string("/proc/self/exe") : p;
}

std::string real(const std::string& path) {
  std::error_code ec;
  auto p = std::filesystem::canonical(path, ec);
  return ec ? path : p.string();
}

int pidfd_open(pid_t pid) { return static_cast<int>(::syscall(SYS_pidfd_open, pid, 0)); }

ExitStatus decode_status(pid_t pid, int st) {
  ExitStatus s;
  s.pid = pid;
  if (WIFEXITED(st)) {
    s.exited = true;
    s.code = WEXITSTATUS(st);
  } else if (WIFSIGNALED(st)) {
    s.signal = WTERMSIG(st);
    s.core = WCOREDUMP(st);
  }
  return s;
}

}  // namespace

std::string signal_name(int sig) {
  if (const char* abbrev = ::sigabbrev_np(sig)) return std::string("SIG") + abbrev;
  return "SIG" + std::to_string(sig);
}

int signal_number(const std::string& name) {
  if (name.empty()) return 0;
  if (std::all_of(name.begin(), name.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    const int n = std::atoi(name.c_str());
    return n > 0 && n < NSIG ? n : 0;
  }
  std::string up;
  for (char c : name) up += static_cast<char>(c >= 'a' && c <= 'z' ? c - 32 : c);
  if (up.rfind("SIG", 0) == 0) up = up.substr(3);
  for (int s = 1; s < NSIG; ++s)
    if (const char* a = ::sigabbrev_np(s); a != nullptr && up == a) return s;
  return 0;
}

std::string ExitStatus::signal_name() const { return exited ? std::string() : dca::signal_name(signal); }

std::string ExitStatus::str() const {
  if (exited) return "exit code " + std::to_string(code);
  return "killed by " + signal_name() + (core ? " (core dumped)" : "");
}

// ---------------------------------------------------------------------------------------------------- AllowList

AllowList AllowList::defaults() {
  AllowList a;
  a.allow("dca", {"node", "supervise", "sim"});
  return a;
}

void AllowList::allow(const std::string& program, std::vector<std::string> first_args) {
  rules_.push_back(Rule{program == "dca" ? real(self_exe()) : real(program), std::move(first_args)});
}

namespace {

// Why a `dca node` argv may not load its packages: each --package a word (a name on the node's own search path,
// controllers/packages.h, never a path), --system-dir absolute. "" when it may. Read as `dca node` reads it
// (app/cmd_node.cpp): option and value in pairs, and only a `--` in an option's place ends them (a `--` given as
// a value, `--name --`, is that value).
std::string package_args_problem(const std::vector<std::string>& argv) {
  for (std::size_t i = 2; i + 1 < argv.size() && argv[i] != "--"; i += 2) {
    const std::string& v = argv[i + 1];
    const bool word = !v.empty() && v.size() <= 64 && !std::isdigit(static_cast<unsigned char>(v[0])) &&
                      std::all_of(v.begin(), v.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
    if (argv[i] == "--package" && !word) return "--package '" + v + "' is not a package name";
    if (argv[i] == "--system-dir" && (v.empty() || v[0] != '/')) return "--system-dir '" + v + "' is not absolute";
  }
  return "";
}

}  // namespace

std::optional<std::string> AllowList::resolve(const std::vector<std::string>& argv, std::string* error) const {
  const auto refuse = [&](std::string why) -> std::optional<std::string> {
    if (error != nullptr) *error = std::move(why);
    return std::nullopt;
  };
  if (argv.empty() || argv[0].empty()) return refuse("spawn needs a non-empty argv");
  const std::string& p = argv[0];
  if (p != "dca" && p[0] != '/') return refuse("not allowed: '" + p + "' (give 'dca' or an absolute path)");
  const std::string path = p == "dca" ? real(self_exe()) : real(p);
  if (path == real(self_exe()) && argv.size() >= 2 && argv[1] == "node")
    if (std::string why = package_args_problem(argv); !why.empty()) return refuse("not allowed: " + why);
  bool program_known = false;
  for (const auto& r : rules_) {
    if (r.program != path) continue;
    program_known = true;
    if (r.first_args.empty()) return path;
    if (argv.size() >= 2 && std::find(r.first_args.begin(), r.first_args.end(), argv[1]) != r.first_args.end())
      return path;
  }
  if (!program_known) return refuse("not allowed: '" + p + "' is not on this daemon's allow-list");
  return refuse("not allowed: '" + p + " " + (argv.size() >= 2 ? argv[1] : std::string()) +
                "' (this daemon allows only some subcommands of it)");
}

// ----------------------------------------------------------------------------------------------------- Executer

struct Executer::Watch {
  ChildId id = 0;
  pid_t pid = 0;
  ExitFn on_exit;
  std::unique_ptr<asio::posix::stream_descriptor> fd;
  bool reaped = false;
  // its stderr pipe (spawn's on_stderr): the read end, the start of a line not ended yet, the exit held until
  // the pipe's end (its last lines first), bounded by `drain`
  LineFn on_stderr;
  std::unique_ptr<asio::posix::stream_descriptor> err;
  std::string partial;
  std::array<char, 4096> buf{};
  std::optional<ExitStatus> held;
  std::unique_ptr<asio::steady_timer> drain;

  // Hands each line ended in `partial` (a longer one in pieces of kMaxLine) to on_stderr; with `all`, the
  // unended rest too.
  void lines_out(bool all) {
    std::size_t start = 0;
    const auto out = [&](std::size_t end) {
      do {
        const std::size_t n = std::min(end - start, kMaxLine);
        if (on_stderr) on_stderr(id, partial.substr(start, n));
        start += n;
      } while (start < end);
    };
    for (std::size_t nl; (nl = partial.find('\n', start)) != std::string::npos; ++start) out(nl);
    while (partial.size() - start >= kMaxLine) out(start + kMaxLine);
    if (all && start < partial.size()) out(partial.size());
    partial.erase(0, start);
  }
};

Executer::Executer(asio::io_context& io, AllowList allow) : io_(io), allow_(std::move(allow)) {}

Executer::~Executer() { stop_all(std::chrono::milliseconds(500)); }

std::optional<Executer::Child> Executer::spawn(const std::vector<std::string>& argv, ExitFn on_exit,
                                               std::string* error, LineFn on_stderr) {
  const auto fail = [&](std::string why) -> std::optional<Child> {
    if (error != nullptr) *error = std::move(why);
    return std::nullopt;
  };
  if (refusing_) return fail("the executer is stopping");
  auto path = allow_.resolve(argv, error);
  if (!path) return std::nullopt;
  // `dca node ...` and `dca supervise ...`: the lean dca-node and dca-supervise beside dca start faster (no
  // Simbody to load), same argv.
  if (argv.size() >= 2 && (argv[1] == "node" || argv[1] == "supervise") && *path == real(self_exe())) {
    const std::string lean = std::filesystem::path(*path).parent_path() / ("dca-" + argv[1]);
    if (::access(lean.c_str(), X_OK) == 0) path = lean;
  }

  SpawnOptions so;
  so.new_group = true;  // its own process group, led by the child
  int pipe_fds[2] = {-1, -1};
  if (on_stderr) {
    if (::pipe2(pipe_fds, O_CLOEXEC) != 0) return fail(std::string("cannot make a pipe: ") + std::strerror(errno));
    ::fcntl(pipe_fds[0], F_SETPIPE_SZ, 1 << 20);  // room for a burst while the loop is busy (best effort)
    so.stderr_fd = pipe_fds[1];
  }
  std::string why;
  const auto spawned = spawn_process(*path, argv, so, &why);
  if (pipe_fds[1] >= 0) ::close(pipe_fds[1]);
  if (!spawned) {
    if (pipe_fds[0] >= 0) ::close(pipe_fds[0]);
    return fail(why);
  }
  const pid_t pid = *spawned;

  auto w = std::make_shared<Watch>();
  w->id = next_id_++;
  w->pid = pid;
  w->on_exit = std::move(on_exit);
  if (pipe_fds[0] >= 0) {
    w->on_stderr = std::move(on_stderr);
    w->err = std::make_unique<asio::posix::stream_descriptor>(io_, pipe_fds[0]);
    read_stderr(w);
  }
  const int pfd = pidfd_open(pid);
  if (pfd < 0) {
    // Without a pidfd we cannot watch it: do not leave it running unwatched.
    ::kill(-pid, SIGKILL);
    int st = 0;
    ::waitpid(pid, &st, 0);
    return fail(std::string("cannot watch the child (pidfd_open: ") + std::strerror(errno) + ")");
  }
  w->fd = std::make_unique<asio::posix::stream_descriptor>(io_, pfd);
  children_[w->id] = w;
  const ChildId id = w->id;
  w->fd->async_wait(asio::posix::stream_descriptor::wait_read, [this, id, w](const boost::system::error_code& ec) {
    if (ec || w->reaped) return;  // cancelled by stop_all
    reaped(id);
  });
  return Child{w->id, pid};
}

void Executer::reaped(ChildId id) {
  auto it = children_.find(id);
  if (it == children_.end()) return;
  auto w = it->second;
  int st = 0;
  pid_t r = 0;
  do {
    r = ::waitpid(w->pid, &st, WNOHANG);
  } while (r < 0 && errno == EINTR);
  if (r == 0) {
    // Readable but not yet waitable: watch again.
    w->fd->async_wait(asio::posix::stream_descriptor::wait_read, [this, id, w](const boost::system::error_code& ec) {
      if (ec || w->reaped) return;
      reaped(id);
    });
    return;
  }
  w->reaped = true;
  children_.erase(it);
  // Whatever the child left in its process group goes with it: no orphans.
  ::kill(-w->pid, SIGKILL);
  boost::system::error_code ec;
  w->fd->close(ec);
  ExitStatus s = r > 0 ? decode_status(w->pid, st) : ExitStatus{w->pid, false, 0, 0, false};
  if (!w->err) return exit_now(w, s);
  // its last lines first: the exit waits for the pipe's end (at once when nothing else holds it), 1 s at most
  w->held = s;
  draining_[id] = w;
  w->drain = std::make_unique<asio::steady_timer>(io_, std::chrono::seconds(1));
  w->drain->async_wait([this, w](const boost::system::error_code& tec) {
    if (!tec && w->err) stderr_ended(w);
  });
}

// Tells the child's end (once).
void Executer::exit_now(const std::shared_ptr<Watch>& w, const ExitStatus& s) {
  if (!w->on_exit) return;
  auto fn = std::move(w->on_exit);
  w->on_exit = nullptr;
  fn(w->id, s);
}

// Its stderr pipe ended (or the wait for its end did): the unended rest of a line goes out, the pipe is closed,
// and a held exit is told.
void Executer::stderr_ended(const std::shared_ptr<Watch>& w) {
  w->lines_out(true);
  boost::system::error_code ec;
  if (w->err) w->err->close(ec);
  w->err.reset();
  if (w->drain) w->drain->cancel();
  if (!w->held) return;
  draining_.erase(w->id);
  exit_now(w, *w->held);
}

// Reads the child's stderr for as long as the pipe is open; its end ends the reading.
void Executer::read_stderr(const std::shared_ptr<Watch>& w) {
  w->err->async_read_some(asio::buffer(w->buf), [this, w](const boost::system::error_code& ec, std::size_t n) {
    if (!w->err) return;  // closed (stop_all, or the wait for its end is over)
    w->partial.append(w->buf.data(), n);
    w->lines_out(false);
    if (ec) return stderr_ended(w);
    read_stderr(w);
  });
}

bool Executer::kill(ChildId child, int signal, std::string* error) {
  auto it = children_.find(child);
  if (it == children_.end()) {
    if (error != nullptr) *error = "no running child " + std::to_string(child);
    return false;
  }
  if (signal <= 0 || signal >= NSIG) {
    if (error != nullptr) *error = "bad signal " + std::to_string(signal);
    return false;
  }
  if (::kill(-it->second->pid, signal) != 0 && ::kill(it->second->pid, signal) != 0) {
    if (error != nullptr) *error = "kill " + std::to_string(it->second->pid) + ": " + std::strerror(errno);
    return false;
  }
  return true;
}

void Executer::stop_all(std::chrono::milliseconds grace) {
  refusing_ = true;
  for (auto& [id, w] : children_) w->on_stderr = nullptr;  // (their pipes are closed below)
  for (auto& [id, w] : std::exchange(draining_, {})) {     // reaped, their exits not told: no callback now
    w->on_exit = nullptr;
    w->on_stderr = nullptr;
    stderr_ended(w);
  }
  if (children_.empty()) return;
  auto children = std::move(children_);
  children_.clear();
  for (auto& [id, w] : children) {
    w->reaped = true;  // no callback
    ::kill(-w->pid, SIGTERM);
  }
  const auto deadline = std::chrono::steady_clock::now() + grace;
  std::vector<std::shared_ptr<Watch>> left;
  for (auto& [id, w] : children) left.push_back(w);
  while (!left.empty()) {
    // Reap what has ended.
    for (auto it = left.begin(); it != left.end();) {
      int st = 0;
      if (::waitpid((*it)->pid, &st, WNOHANG) != 0) {
        ::kill(-(*it)->pid, SIGKILL);
        it = left.erase(it);
      } else {
        ++it;
      }
    }
    const auto now = std::chrono::steady_clock::now();
    if (left.empty() || now >= deadline) break;
    std::vector<pollfd> fds;
    for (auto& w : left) fds.push_back(pollfd{w->fd->native_handle(), POLLIN, 0});
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - now).count();
    ::poll(fds.data(), fds.size(), static_cast<int>(std::max<std::int64_t>(1, ms)));
  }
  for (auto& w : left) {
    ::kill(-w->pid, SIGKILL);
    ::kill(w->pid, SIGKILL);
    int st = 0;
    while (::waitpid(w->pid, &st, 0) < 0 && errno == EINTR) {
    }
  }
  for (auto& [id, w] : children) {
    boost::system::error_code ec;
    w->fd->close(ec);
    if (w->err) w->err->close(ec);
    w->err.reset();
  }
}

std::map<Executer::ChildId, pid_t> Executer::children() const {
  std::map<ChildId, pid_t> out;
  for (const auto& [id, w] : children_) out[id] = w->pid;
  return out;
}

}  // namespace dca
