#pragma once
// Open-loop command scripts for `dca sim --world door --world-opt script=FILE`. C++17-clean.
//
// One command per line, `TIME WORD ARGS...`, times in seconds and non-decreasing; `#` starts a comment.
//   T base VX VY WZ      base velocity in the base frame (m/s, m/s, rad/s), held until the next base line
//   T arm Q1 ... Q6      arm joint rates (rad/s), held until the next arm line
//   T gripper open|close
//   T stop               zero base and arm rates (the gripper stays as it is)
//   T door               from T on, the built-in scripted door opening (ScriptedDoorOpening) drives the robot
//   T end                the run ends at T
#include <string>
#include <vector>

#include "worlds/door/world.h"

namespace dca::sim {

/// One line of a script.
struct ScriptLine {
  enum Kind { base, arm, gripper, stop, door, end } kind = stop;
  double time = 0;
  std::array<double, 6> values{};  ///< base: 3 used; arm: 6; gripper: values[0] = 1 close, 0 open
};

/// A parsed script and its playback.
class Script {
 public:
  /// Parses `text` into *out; `name` stands for the file in errors. False with *error ("FILE:LINE:COL: reason")
  /// at the first bad line (*out unchanged).
  static bool parse(const std::string& text, const std::string& name, Script* out, std::string* error);
  /// Reads and parses a file, as parse.
  static bool load(const std::string& path, Script* out, std::string* error);

  const std::vector<ScriptLine>& lines() const { return lines_; }
  /// Applies every line whose time has come (time <= t) to `c`. Returns false once an `end` line is reached.
  bool advance(double t, Commands& c);
  /// True once a `door` line has been reached.
  bool door_mode() const { return door_; }
  /// The time of the `end` line, or -1.
  double end_time() const;

 private:
  std::vector<ScriptLine> lines_;
  size_t next_ = 0;
  bool door_ = false;
};

}  // namespace dca::sim
