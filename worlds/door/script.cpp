#include "worlds/door/script.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <utility>

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

// One line's parse; errors name the file, the line and the token's column.
struct LineParser {
  const std::string& name;
  int number;
  const std::vector<Token>& t;
  std::string* error;

  bool fail(const Token& at, const std::string& why) {
    *error = name + ":" + std::to_string(number) + ":" + std::to_string(at.column) + ": " + why;
    return false;
  }

  bool number_at(const Token& tok, double* v) {
    char* endp = nullptr;
    *v = std::strtod(tok.text.c_str(), &endp);
    if (endp == tok.text.c_str() || *endp != '\0' || !std::isfinite(*v))
      return fail(tok, "expected a number, found '" + tok.text + "'");
    return true;
  }

  // The command word: its kind and how many arguments it takes.
  bool command(ScriptLine* l, size_t* want) {
    const std::string& word = t[1].text;
    *want = 0;
    if (word == "base") l->kind = ScriptLine::base, *want = 3;
    else if (word == "arm") l->kind = ScriptLine::arm, *want = 6;
    else if (word == "gripper") l->kind = ScriptLine::gripper, *want = 1;
    else if (word == "stop") l->kind = ScriptLine::stop;
    else if (word == "door") l->kind = ScriptLine::door;
    else if (word == "end") l->kind = ScriptLine::end;
    else return fail(t[1], "unknown command '" + word + "' (base, arm, gripper, stop, door, end)");
    if (t.size() == *want + 2) return true;
    const Token& at = t.size() > *want + 2 ? t[*want + 2] : t.back();
    return fail(at, "'" + word + "' takes " + std::to_string(*want) + " argument" + (*want == 1 ? "" : "s") +
                        ", found " + std::to_string(t.size() - 2));
  }

  // TIME WORD ARGS, at or after `last`.
  bool parse(double last, ScriptLine* l) {
    if (!number_at(t[0], &l->time)) return false;
    if (l->time < last) return fail(t[0], "time goes backwards (" + t[0].text + " after " + std::to_string(last) + ")");
    if (t.size() < 2) return fail(t[0], "expected a command after the time");
    size_t want = 0;
    if (!command(l, &want)) return false;
    if (l->kind != ScriptLine::gripper) {
      for (size_t i = 0; i < want; ++i)
        if (!number_at(t[i + 2], &l->values[i])) return false;
      return true;
    }
    if (t[2].text != "open" && t[2].text != "close") return fail(t[2], "expected open or close");
    l->values[0] = t[2].text == "close" ? 1 : 0;
    return true;
  }
};

}  // namespace

bool Script::parse(const std::string& text, const std::string& name, Script* out, std::string* error) {
  Script s;
  std::istringstream in(text);
  std::string line;
  int number = 0;
  double last = 0;
  while (std::getline(in, line)) {
    ++number;
    const std::vector<Token> t = split(line);
    if (t.empty()) continue;
    ScriptLine l;
    if (!LineParser{name, number, t, error}.parse(last, &l)) return false;
    last = l.time;
    s.lines_.push_back(l);
  }
  *out = std::move(s);
  return true;
}

bool Script::load(const std::string& path, Script* out, std::string* error) {
  std::ifstream in(path);
  if (!in) return *error = path + ": cannot open the script", false;
  std::ostringstream text;
  text << in.rdbuf();
  return parse(text.str(), path, out, error);
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
