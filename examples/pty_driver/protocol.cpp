#include "protocol.h"

#include <charconv>
#include <cmath>

namespace pty_driver {

namespace {

// The body of a framed line "BODY*HH", or false when the frame or its checksum is wrong.
bool unframe(std::string_view line, std::string_view* body) {
  if (line.size() < 3 || line[line.size() - 3] != '*') return false;
  unsigned sum = 0;
  const char* hh = line.data() + line.size() - 2;
  const auto r = std::from_chars(hh, hh + 2, sum, 16);
  if (r.ec != std::errc() || r.ptr != hh + 2) return false;
  *body = line.substr(0, line.size() - 3);
  return checksum(*body) == sum;
}

// Splits `s` at single spaces into at most N fields; the number of fields, or N + 1 when there are more.
template <std::size_t N>
std::size_t split(std::string_view s, std::array<std::string_view, N>& out) {
  std::size_t n = 0;
  while (true) {
    const auto sp = s.find(' ');
    if (n == N) return N + 1;
    out[n++] = s.substr(0, sp);
    if (sp == std::string_view::npos) return n;
    s.remove_prefix(sp + 1);
  }
}

// A whole field as a finite number.
bool number(std::string_view f, double* x) {
  if (f.empty()) return false;
  const auto r = std::from_chars(f.data(), f.data() + f.size(), *x);
  return r.ec == std::errc() && r.ptr == f.data() + f.size() && std::isfinite(*x);
}

template <class I>
bool integer(std::string_view f, I* x) {
  if (f.empty()) return false;
  const auto r = std::from_chars(f.data(), f.data() + f.size(), *x);
  return r.ec == std::errc() && r.ptr == f.data() + f.size();
}

// Appends `x` to buf at *at (9 significant digits: at most 16 characters); false when it does not fit.
bool put_number(double x, char* buf, std::size_t cap, std::size_t* at) {
  const auto r = std::to_chars(buf + *at, buf + cap, x, std::chars_format::general, 9);
  if (r.ec != std::errc()) return false;
  *at = static_cast<std::size_t>(r.ptr - buf);
  return true;
}

bool put(std::string_view s, char* buf, std::size_t cap, std::size_t* at) {
  if (cap - *at < s.size()) return false;
  for (const char c : s) buf[(*at)++] = c;
  return true;
}

// Ends the body written in buf[0, at) with "*HH\n"; the line's length, or 0 when it does not fit.
std::size_t close_frame(char* buf, std::size_t cap, std::size_t at) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  if (cap - at < 4 || at > kMaxLine - 3) return 0;
  const std::uint8_t sum = checksum(std::string_view(buf, at));
  buf[at++] = '*';
  buf[at++] = kHex[sum >> 4];
  buf[at++] = kHex[sum & 15];
  buf[at++] = '\n';
  return at;
}

}  // namespace

std::string_view to_string(LineError e) {
  switch (e) {
    case LineError::none: return "ok";
    case LineError::checksum: return "bad checksum";
    case LineError::garbled: return "garbled";
  }
  return "?";
}

std::uint8_t checksum(std::string_view body) {
  std::uint8_t sum = 0;
  for (const char c : body) sum ^= static_cast<std::uint8_t>(c);
  return sum;
}

LineError parse_state(std::string_view line, State* out) {
  std::string_view body;
  if (!unframe(line, &body)) return LineError::checksum;
  std::array<std::string_view, 2 + 3 * kJoints> f;
  if (split(body, f) != f.size() || f[0] != "S") return LineError::garbled;
  State s;
  if (!integer(f[1], &s.t_ms)) return LineError::garbled;
  for (std::size_t j = 0; j < kJoints; ++j) {
    if (!number(f[2 + j], &s.q[j]) || !number(f[2 + kJoints + j], &s.qd[j]) ||
        !number(f[2 + 2 * kJoints + j], &s.effort[j]))
      return LineError::garbled;
  }
  *out = s;
  return LineError::none;
}

LineError parse_command(std::string_view line, Command* out) {
  std::string_view body;
  if (!unframe(line, &body)) return LineError::checksum;
  std::array<std::string_view, 4> f;
  Command c;
  if (split(body, f) != f.size() || f[0] != "C" || !integer(f[1], &c.joint) || c.joint >= kJoints ||
      (f[2] != "P" && f[2] != "V") || !number(f[3], &c.value))
    return LineError::garbled;
  c.mode = f[2][0];
  *out = c;
  return LineError::none;
}

std::size_t format_state(const State& s, char* buf, std::size_t cap) {
  std::size_t at = 0;
  if (!put("S ", buf, cap, &at)) return 0;
  const auto r = std::to_chars(buf + at, buf + cap, s.t_ms);
  if (r.ec != std::errc()) return 0;
  at = static_cast<std::size_t>(r.ptr - buf);
  for (const auto* v : {&s.q, &s.qd, &s.effort}) {
    for (const double x : *v) {
      if (!put(" ", buf, cap, &at) || !put_number(x, buf, cap, &at)) return 0;
    }
  }
  return close_frame(buf, cap, at);
}

std::size_t format_command(const Command& c, char* buf, std::size_t cap) {
  std::size_t at = 0;
  const char head[] = {'C', ' ', static_cast<char>('0' + c.joint % 10), ' ', c.mode, ' '};
  if (c.joint >= kJoints || !put(std::string_view(head, sizeof head), buf, cap, &at) ||
      !put_number(c.value, buf, cap, &at))
    return 0;
  return close_frame(buf, cap, at);
}

}  // namespace pty_driver
