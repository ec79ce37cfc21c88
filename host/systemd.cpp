#include "host/systemd.h"

#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdarg>
#include <cstdlib>
#include <cstring>

namespace dca::systemd {

namespace {

// $JOURNAL_STREAM against stderr's device and inode (systemd.exec(5), "JOURNAL_STREAM").
bool journal_check() {
  const char* e = std::getenv("JOURNAL_STREAM");
  if (e == nullptr || *e == '\0') return false;
  unsigned long long dev = 0, ino = 0;
  if (std::sscanf(e, "%llu:%llu", &dev, &ino) != 2) return false;
  struct stat st {};
  if (::fstat(STDERR_FILENO, &st) != 0) return false;
  return static_cast<unsigned long long>(st.st_dev) == dev && static_cast<unsigned long long>(st.st_ino) == ino;
}

// Takes variable `name` out of the environment: its value, "" when unset.
std::string take_env(const char* name) {
  const char* v = std::getenv(name);
  std::string value = v != nullptr ? v : "";
  ::unsetenv(name);
  return value;
}

}  // namespace

bool stderr_is_journal() {
  static const bool journal = journal_check();
  return journal;
}

void log_line(Priority p, const std::string& line) {
  std::string text;
  text.reserve(line.size() + 5);
  if (stderr_is_journal()) {  // one digit: syslog's priorities are 0..7
    text += '<';
    text += static_cast<char>('0' + static_cast<int>(p));
    text += '>';
  }
  text += line;
  text += '\n';
  std::size_t done = 0;
  while (done < text.size()) {  // one write per line when the pipe takes it whole
    const ssize_t n = ::write(STDERR_FILENO, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    done += static_cast<std::size_t>(n);
  }
}

void log(Priority p, const char* format, ...) {
  char small[512];
  va_list args;
  va_start(args, format);
  const int n = std::vsnprintf(small, sizeof small, format, args);
  va_end(args);
  if (n < 0) return;
  if (static_cast<std::size_t>(n) < sizeof small) return log_line(p, std::string(small, static_cast<std::size_t>(n)));
  std::string big(static_cast<std::size_t>(n) + 1, '\0');
  va_start(args, format);
  std::vsnprintf(big.data(), big.size(), format, args);
  va_end(args);
  big.resize(static_cast<std::size_t>(n));
  log_line(p, big);
}

Notifier::Notifier() {
  socket_ = take_env("NOTIFY_SOCKET");
  const std::string usec = take_env("WATCHDOG_USEC"), pid = take_env("WATCHDOG_PID");
  const long long period = std::atoll(usec.c_str());
  const bool ours = pid.empty() || std::atoll(pid.c_str()) == static_cast<long long>(::getpid());
  if (period > 0 && ours) watchdog_ = std::chrono::microseconds(period);
}

Notifier::~Notifier() = default;

bool Notifier::notify(const std::string& state, std::string* error) const {
  if (socket_.empty()) return false;
  const auto fail = [&](const std::string& why) {
    if (error != nullptr) *error = "sd_notify to " + socket_ + ": " + why;
    return false;
  };
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (socket_.size() >= sizeof addr.sun_path || (socket_[0] != '/' && socket_[0] != '@')) {
    return fail("not an absolute path or an abstract socket name");
  }
  std::memcpy(addr.sun_path, socket_.data(), socket_.size());
  if (socket_[0] == '@') addr.sun_path[0] = '\0';  // Linux's abstract namespace
  const auto len = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + socket_.size());
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return fail(std::strerror(errno));
  const ssize_t n = ::sendto(fd, state.data(), state.size(), MSG_NOSIGNAL, reinterpret_cast<sockaddr*>(&addr), len);
  const int saved = errno;
  ::close(fd);
  if (n != static_cast<ssize_t>(state.size())) return fail(n < 0 ? std::strerror(saved) : "short write");
  return true;
}

void Notifier::send_or_say(const std::string& state) {
  std::string error;
  if (notify(state, &error) || error.empty() || said_error_) return;
  said_error_ = true;  // once: a watchdog that cannot be fed would otherwise fill the log
  log(Priority::warning, "%s", error.c_str());
}

void Notifier::ready(boost::asio::io_context& io, const std::string& status) {
  if (!enabled()) return;
  send_or_say("READY=1\nSTATUS=" + status);
  if (watchdog_.count() > 0) {
    timer_ = std::make_unique<boost::asio::steady_timer>(io);
    arm_watchdog();
  }
}

void Notifier::arm_watchdog() {
  timer_->expires_after(watchdog_ / 2);  // sd_watchdog_enabled(3): notify at half the period
  timer_->async_wait([this](const boost::system::error_code& ec) {
    if (ec || !timer_) return;
    ++watchdogs_;
    send_or_say("WATCHDOG=1");
    arm_watchdog();
  });
}

void Notifier::stopping(const std::string& status) {
  if (timer_) timer_->cancel();
  timer_.reset();
  if (enabled()) send_or_say("STOPPING=1\nSTATUS=" + status);
}

}  // namespace dca::systemd
