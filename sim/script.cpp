#include "sim/script.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace dca::sim {
namespace {

struct Token {
  std::string text;
  size_t column;  // 1-based
};

std::vector<Token> split(const std::string& line) {
  std::vector<Token> out;
  size_t i = 0;
  const size_t end = line.find('#') == std::string::npos ? line.size() : line.find('#');
  while (i < end) {
    while (i < end && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    if (i >= end) break;
    const size_t start = i;
    while (i < end && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    out.push_back({line.substr(start, i - start), start + 1});
  }
  return out;
}

}  // namespace

Script Script::parse(const std::string& text, const std::string& name) {
  Script s;
  std::istringstream in(text);
  std::string line;
  int number = 0;
  double last = 0;
  while (std::getline(in, line)) {
    ++number;
    const std::vector<Token> t = split(line);
    if (t.empty()) continue;
    const auto error = [&](const Token& at, const std::string& why) {
      return ScriptError(name + ":" + std::to_string(number) + ":" + std::to_string(at.column) + ": " + why);
    };
    const auto number_at = [&](const Token& tok) {
      char* endp = nullptr;
      const double v = std::strtod(tok.text.c_str(), &endp);
      if (endp == tok.text.c_str() || *endp != '\0' || !std::isfinite(v))
        throw error(tok, "expected a number, found '" + tok.text + "'");
      return v;
    };
    ScriptLine l;
    l.time = number_at(t[0]);
    if (l.time < last) throw error(t[0], "time goes backwards (" + t[0].text + " after " + std::to_string(last) + ")");
    last = l.time;
    if (t.size() < 2) throw error(t[0], "expected a command after the time");
    const std::string& word = t[1].text;
    size_t want = 0;
    if (word == "base") l.kind = ScriptLine::base, want = 3;
    else if (word == "arm") l.kind = ScriptLine::arm, want = 6;
    else if (word == "gripper") l.kind = ScriptLine::gripper, want = 1;
    else if (word == "stop") l.kind = ScriptLine::stop;
    else if (word == "door") l.kind = ScriptLine::door;
    else if (word == "end") l.kind = ScriptLine::end;
    else throw error(t[1], "unknown command '" + word + "' (base, arm, gripper, stop, door, end)");
    if (t.size() != want + 2) {
      const Token& at = t.size() > want + 2 ? t[want + 2] : t.back();
      throw error(at, "'" + word + "' takes " + std::to_string(want) + " argument" + (want == 1 ? "" : "s") +
                          ", found " + std::to_string(t.size() - 2));
    }
    if (l.kind == ScriptLine::gripper) {
      if (t[2].text != "open" && t[2].text != "close") throw error(t[2], "expected open or close");
      l.values[0] = t[2].text == "close" ? 1 : 0;
    } else {
      for (size_t i = 0; i < want; ++i) l.values[i] = number_at(t[i + 2]);
    }
    s.lines_.push_back(l);
  }
  return s;
}

Script Script::load(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ScriptError(path + ": cannot open the script");
  std::ostringstream text;
  text << in.rdbuf();
  return parse(text.str(), path);
}

bool Script::advance(double t, Commands& c) {
  while (next_ < lines_.size() && lines_[next_].time <= t + 1e-12) {
    const ScriptLine& l = lines_[next_++];
    switch (l.kind) {
      case ScriptLine::base:
        c.base_vel = {l.values[0], l.values[1], l.values[2]};
        break;
      case ScriptLine::arm:
        c.arm_qd = l.values;
        break;
      case ScriptLine::gripper:
        c.gripper_close = l.values[0] != 0;
        break;
      case ScriptLine::stop:
        c.base_vel = {};
        c.arm_qd = {};
        break;
      case ScriptLine::door:
        door_ = true;
        break;
      case ScriptLine::end:
        return false;
    }
  }
  return true;
}

double Script::end_time() const {
  for (const auto& l : lines_)
    if (l.kind == ScriptLine::end) return l.time;
  return -1;
}

}  // namespace dca::sim
