#pragma once
// The serial line protocol between the driver (serial_arm.cpp) and the arm (device/pty_arm.cpp), as
// docs/drivers.md ("The example's line protocol") specifies it: NMEA-like ASCII lines "BODY*HH\n", HH the XOR of
// BODY's bytes in two hex digits, at most kMaxLine bytes before the newline; numbers with 9 significant digits.
//   arm -> driver   S T q1 .. q6 qd1 .. qd6 e1 .. e6     state at the arm's time T (ms): rad, rad/s, N m
//   driver -> arm   C J P x   or   C J V x               joint J (0-5): position target x (rad), velocity x (rad/s)
// Pure and allocation-free: any bytes in give counted errors, never a crash (tests/protocol_test.cpp).
#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "arm.h"

namespace pty_driver {

inline constexpr std::size_t kMaxLine = 400;  ///< a state line takes at most 331

/// What was wrong with a line.
enum class LineError : std::uint8_t {
  none,
  checksum,  ///< no "*HH", or HH is not the XOR of the body
  garbled,   ///< framed right, but not a state or command line: a wrong field count, a number that does not parse
             ///< or is not finite, an unknown kind or joint
};
/// "ok", "bad checksum", "garbled".
std::string_view to_string(LineError e);

/// A state line's content.
struct State {
  std::int64_t t_ms = 0;
  std::array<double, kJoints> q{}, qd{}, effort{};
};

/// A command line's content.
struct Command {
  std::size_t joint = 0;
  char mode = 'P';  ///< 'P' position, 'V' velocity
  double value = 0;
};

/// Splits a byte stream into lines (without "\n" or "\r\n"). A line longer than kMaxLine is dropped up to its
/// newline and counted. Holds at most kMaxLine bytes.
class LineReader {
 public:
  /// Feeds n bytes; calls on_line(std::string_view) for every complete line in them.
  template <class F>
  void feed(const char* data, std::size_t n, F&& on_line) {
    for (std::size_t i = 0; i < n; ++i) {
      const char c = data[i];
      if (c == '\n') {
        if (!skipping_) {
          std::size_t len = len_;
          if (len > 0 && buf_[len - 1] == '\r') --len;
          on_line(std::string_view(buf_.data(), len));
        }
        len_ = 0;
        skipping_ = false;
      } else if (skipping_) {
        continue;
      } else if (len_ == kMaxLine) {
        skipping_ = true;
        len_ = 0;
        ++overlong_;
      } else {
        buf_[len_++] = c;
      }
    }
  }
  /// Lines dropped for being too long.
  std::uint64_t overlong() const { return overlong_; }
  /// Forgets a partial line.
  void reset() {
    len_ = 0;
    skipping_ = false;
  }

 private:
  std::array<char, kMaxLine> buf_{};
  std::size_t len_ = 0;
  bool skipping_ = false;
  std::uint64_t overlong_ = 0;
};

/// The XOR of the bytes of `body`.
std::uint8_t checksum(std::string_view body);

/// Reads a state line ("S ...*HH", no newline) into *out (untouched on an error).
LineError parse_state(std::string_view line, State* out);
/// Reads a command line ("C ...*HH", no newline) into *out (untouched on an error).
LineError parse_command(std::string_view line, Command* out);

/// Writes the framed line of `s` ("S ...*HH\n") into buf; its length, or 0 when it does not fit in cap.
std::size_t format_state(const State& s, char* buf, std::size_t cap);
/// Writes the framed line of `c` ("C J P x*HH\n") into buf; its length, or 0 when it does not fit in cap.
std::size_t format_command(const Command& c, char* buf, std::size_t cap);

}  // namespace pty_driver
