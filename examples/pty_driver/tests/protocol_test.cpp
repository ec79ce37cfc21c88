// The line protocol (protocol.h) on what a serial line can bring: partial lines, garbage, overlong lines, lines
// that frame right but say nothing valid. Every input gives a counted error, never a crash.
#include "protocol.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

using namespace pty_driver;

namespace {

State sample_state() {
  State s;
  s.t_ms = 1234;
  for (std::size_t j = 0; j < kJoints; ++j) {
    s.q[j] = kArm[j].start + 0.125 * static_cast<double>(j);
    s.qd[j] = -0.5 * static_cast<double>(j);
    s.effort[j] = 1e-7 * static_cast<double>(j + 1);
  }
  return s;
}

std::string state_line(const State& s) {
  std::array<char, kMaxLine + 1> buf;
  const std::size_t n = format_state(s, buf.data(), buf.size());
  return std::string(buf.data(), n);
}

// "BODY*HH" with the right checksum.
std::string framed(const std::string& body) {
  char hh[4];
  std::snprintf(hh, sizeof hh, "%02X", checksum(body));
  return body + "*" + hh;
}

// The lines a reader gives for `chunks` fed one after another.
std::vector<std::string> lines_of(LineReader& r, const std::vector<std::string>& chunks) {
  std::vector<std::string> out;
  for (const auto& c : chunks) r.feed(c.data(), c.size(), [&](std::string_view l) { out.emplace_back(l); });
  return out;
}

}  // namespace

TEST(Protocol, AStateLineReadsBackWhatWasWritten) {
  const State s = sample_state();
  const std::string line = state_line(s);
  ASSERT_FALSE(line.empty());
  ASSERT_EQ(line.back(), '\n');
  EXPECT_LE(line.size() - 1, kMaxLine);
  State got;
  ASSERT_EQ(parse_state(line.substr(0, line.size() - 1), &got), LineError::none);
  EXPECT_EQ(got.t_ms, 1234);
  for (std::size_t j = 0; j < kJoints; ++j) {
    EXPECT_NEAR(got.q[j], s.q[j], 1e-8);
    EXPECT_NEAR(got.qd[j], s.qd[j], 1e-8);
    EXPECT_NEAR(got.effort[j], s.effort[j], 1e-15);
  }
}

TEST(Protocol, TheLongestStateLineFits) {
  State s;
  s.t_ms = INT64_MIN;
  s.q.fill(-1.23456789e-300);
  s.qd.fill(-1.23456789e-300);
  s.effort.fill(-1.23456789e-300);
  EXPECT_FALSE(state_line(s).empty());
}

TEST(Protocol, ACommandLineReadsBack) {
  std::array<char, kMaxLine + 1> buf;
  const std::size_t n = format_command({.joint = 2, .mode = 'V', .value = -0.75}, buf.data(), buf.size());
  ASSERT_GT(n, 0u);
  Command c;
  ASSERT_EQ(parse_command(std::string_view(buf.data(), n - 1), &c), LineError::none);
  EXPECT_EQ(c.joint, 2u);
  EXPECT_EQ(c.mode, 'V');
  EXPECT_EQ(c.value, -0.75);
  EXPECT_EQ(format_command({.joint = 6, .mode = 'P', .value = 0}, buf.data(), buf.size()), 0u);
  EXPECT_EQ(format_command({.joint = 0, .mode = 'P', .value = 0}, buf.data(), 5), 0u);  // does not fit
}

TEST(Protocol, PartialLinesAreJoinedAcrossReads) {
  LineReader r;
  const std::string line = state_line(sample_state());
  std::vector<std::string> chunks;
  for (std::size_t at = 0; at < line.size(); at += 7) chunks.push_back(line.substr(at, 7));
  const auto lines = lines_of(r, chunks);
  ASSERT_EQ(lines.size(), 1u);
  State s;
  EXPECT_EQ(parse_state(lines[0], &s), LineError::none);
  EXPECT_TRUE(lines_of(r, {"S 1 2"}).empty());  // no newline yet: nothing
  EXPECT_EQ(lines_of(r, {" 3\r\n"}), std::vector<std::string>{"S 1 2 3"});  // "\r\n" ends a line too
}

TEST(Protocol, AnOverlongLineIsDroppedUpToItsNewlineAndCounted) {
  LineReader r;
  const std::string good = state_line(sample_state());
  const auto lines = lines_of(r, {std::string(kMaxLine, 'x'), "yyy", std::string(3 * kMaxLine, 'z') + "\n", good});
  EXPECT_EQ(r.overlong(), 1u);
  ASSERT_EQ(lines.size(), 1u);  // the good line after it, whole
  State s;
  EXPECT_EQ(parse_state(lines[0], &s), LineError::none);
  EXPECT_EQ(lines_of(r, {std::string(kMaxLine, 'k') + "\n"}).size(), 1u);  // kMaxLine itself is allowed
  EXPECT_EQ(r.overlong(), 1u);
}

TEST(Protocol, ABadChecksumIsNamed) {
  std::string line = state_line(sample_state());
  line.pop_back();
  line[10] = static_cast<char>(line[10] ^ 0x21);
  State s = sample_state(), before = s;
  EXPECT_EQ(parse_state(line, &s), LineError::checksum);
  EXPECT_EQ(s.q, before.q);  // untouched
  for (const char* l : {"", "*", "S 1*", "S 1*G0", "S 1*0", "no star at all", "*00"}) {
    EXPECT_NE(parse_state(l, &s), LineError::none) << l;
  }
  EXPECT_EQ(to_string(LineError::checksum), "bad checksum");
}

TEST(Protocol, FramedLinesThatSayNothingValidAreGarbled) {
  State s;
  const std::string fields = " 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18";
  EXPECT_EQ(parse_state(framed("S 10" + fields), &s), LineError::none);
  const std::vector<std::string> bodies = {
        "S 10" + fields + " 19", "S 10 1 2", "X 10" + fields, "S 1.5" + fields, "S 10 nan" + fields.substr(2),
        "S 10 inf" + fields.substr(2), "S 10 1e999" + fields.substr(2), "S  10" + fields, "S 10" + fields + " ",
        std::string("S 10 1\0" "2", 8) + fields.substr(4), "S 10 0x1" + fields.substr(2), "C 0 P 1 2", "C 6 P 1",
        "C 0 Q 1", "C -1 P 1", "C 0 P", "C 0 V nan", "C 0 P 1e400"};
  for (const std::string& body : bodies) {
    Command c;
    EXPECT_EQ(parse_state(framed(body), &s), LineError::garbled) << body;
    EXPECT_NE(parse_command(framed(body), &c), LineError::none) << body;
  }
  Command c;
  EXPECT_EQ(parse_command(framed("C 5 P -1.5"), &c), LineError::none);
  EXPECT_EQ(c.joint, 5u);
}

// Random bytes, random splits: every line found is an error or a valid line, the reader never holds more than a
// line, and nothing crashes (the sanitizers watch when dca is built with them).
TEST(Protocol, RandomBytesGiveCountedErrors) {
  std::mt19937 rng(42);
  LineReader r;
  std::size_t lines = 0, valid = 0;
  const std::string good = state_line(sample_state());
  for (int round = 0; round < 2000; ++round) {
    std::string chunk(rng() % 600, '\0');
    for (auto& ch : chunk) ch = static_cast<char>(rng() % 8 == 0 ? '\n' : rng() % 256);
    if (round % 10 == 0) chunk += "\n" + good;  // a valid line now and then, after a newline
    r.feed(chunk.data(), chunk.size(), [&](std::string_view l) {
      ++lines;
      EXPECT_LE(l.size(), kMaxLine);
      State s;
      Command c;
      if (parse_state(l, &s) == LineError::none) ++valid;
      (void)parse_command(l, &c);
    });
  }
  EXPECT_GT(lines, 1000u);
  EXPECT_EQ(valid, 200u);  // every good line, whatever came before it
}
