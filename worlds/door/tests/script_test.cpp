// Open-loop command scripts: parsing (errors with file:line:col) and playback.
#include "worlds/door/script.h"

#include <gtest/gtest.h>

namespace {

using dca::sim::Commands;
using dca::sim::Script;
std::string error_of(const std::string& text) {
  Script s;
  std::string error;
  if (!Script::parse(text, "s.txt", &s, &error)) return error;
  return "";
}

TEST(ScriptTest, PlaysCommandsAtTheirTimes) {
  Script s;
  std::string error;
  ASSERT_TRUE(Script::parse(
      "# drive, then wave\n"
      "0   base 0.2 0 0.1\n"
      "1.5 arm 0.1 0 0 0 0 -0.2   # joint rates\n"
      "2   gripper close\n"
      "3   stop\n"
      "4   door\n"
      "9   end\n",
      "s.txt", &s, &error))
      << error;
  ASSERT_EQ(s.lines().size(), 6u);
  EXPECT_EQ(s.end_time(), 9.0);
  Commands c;
  EXPECT_TRUE(s.advance(0.0, c));
  EXPECT_EQ(c.base_vel, (std::array<double, 3>{0.2, 0, 0.1}));
  EXPECT_EQ(c.arm_qd, (std::array<double, 6>{}));
  EXPECT_TRUE(s.advance(1.499, c));
  EXPECT_EQ(c.arm_qd[0], 0.0);
  EXPECT_TRUE(s.advance(2.0, c));
  EXPECT_EQ(c.arm_qd[5], -0.2);
  EXPECT_TRUE(c.gripper_close);
  EXPECT_FALSE(s.door_mode());
  EXPECT_TRUE(s.advance(4.0, c));
  EXPECT_EQ(c.base_vel, (std::array<double, 3>{}));
  EXPECT_TRUE(c.gripper_close);
  EXPECT_TRUE(s.door_mode());
  EXPECT_FALSE(s.advance(9.0, c));
}

TEST(ScriptTest, ErrorsNameFileLineAndColumn) {
  EXPECT_EQ(error_of("0 base 1 2\n"), "s.txt:1:10: 'base' takes 3 arguments, found 2");
  EXPECT_EQ(error_of("0 stop\n\n 1 fly\n"), "s.txt:3:4: unknown command 'fly' (base, arm, gripper, stop, door, end)");
  EXPECT_EQ(error_of("0 arm 1 2 x 4 5 6\n"), "s.txt:1:11: expected a number, found 'x'");
  EXPECT_EQ(error_of("2 stop\n1 stop\n"), "s.txt:2:1: time goes backwards (1 after 2.000000)");
  EXPECT_EQ(error_of("0 gripper shut\n"), "s.txt:1:11: expected open or close");
  EXPECT_EQ(error_of("0 stop now\n"), "s.txt:1:8: 'stop' takes 0 arguments, found 1");
  EXPECT_EQ(error_of("soon stop\n"), "s.txt:1:1: expected a number, found 'soon'");
  EXPECT_EQ(error_of("# nothing but comments\n\n"), "");
}

TEST(ScriptTest, MissingFileIsNamed) {
  Script s;
  std::string error;
  EXPECT_FALSE(Script::load("/nonexistent/script.txt", &s, &error)) << "loaded a missing file";
  EXPECT_EQ(error, "/nonexistent/script.txt: cannot open the script");
}

}  // namespace
