#include "sim/urdf/joint_world.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "sim/urdf/frames.h"

namespace dca::sim {
namespace {

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string part; std::getline(in, part, sep);)
    if (!part.empty()) out.push_back(part);
  return out;
}

// Reads option `kv` ("lag=S", "dead=J1,J2") of a mock spec into `out`: "" or what is wrong.
std::string mock_option(const std::string& kv, RobotWorldSpec* out) {
  const auto eq = kv.find('=');
  const std::string key = kv.substr(0, eq), value = eq == std::string::npos ? "" : kv.substr(eq + 1);
  if (key == "lag") {
    char* end = nullptr;
    out->lag = std::strtod(value.c_str(), &end);
    if (value.empty() || *end != '\0' || !(out->lag >= 0) || !std::isfinite(out->lag))
      return "lag needs seconds, 0 or more (e.g. lag=0.05)";
    return "";
  }
  if (key == "dead") {
    out->dead = split(value, ',');
    return out->dead.empty() ? "dead needs joint names (e.g. dead=elbow_joint,wrist_1_joint)" : "";
  }
  return "unknown option '" + key + "' (lag=S, dead=J1,J2)";
}

}  // namespace

bool is_robot_world(const std::string& spec) {
  const std::string file = spec.substr(0, spec.find('?'));
  return ends_with(file, ".urdf") || spec.compare(0, 5, "mock:") == 0;
}

bool parse_world_spec(const std::string& spec, RobotWorldSpec* out, std::string* error) {
  *out = {};
  std::string rest = spec;
  if (rest.compare(0, 5, "mock:") == 0) out->mock = true, rest = rest.substr(5);
  const auto q = rest.find('?');
  out->file = rest.substr(0, q);
  if (out->file.empty()) return *error = "world '" + spec + "': no URDF file named", false;
  if (q == std::string::npos) return true;
  if (!out->mock) return *error = "world '" + spec + "': options (?lag=, ?dead=) are the mock's: mock:FILE?...", false;
  for (const auto& kv : split(rest.substr(q + 1), '&'))
    if (const std::string why = mock_option(kv, out); !why.empty()) return *error = "world '" + spec + "': " + why, false;
  return true;
}

std::size_t signal_index(const std::vector<DeviceSignal>& signals, const std::string& name) {
  for (std::size_t i = 0; i < signals.size(); ++i)
    if (signals[i].name == name) return i;
  return signals.size();
}

JointWorld::JointWorld(RobotDescription description, double period)
    : description_(std::move(description)), interfaces_(description_), period_(period) {
  if (!(period > 0 && period <= 0.01)) throw std::invalid_argument("period must be in (0, 10 ms]");
  for (const auto& j : description_.joints) state_.push_back({j.initial, 0, 0});
  sensors_ = joint_sensor_signals(description_);
  commands_ = joint_command_signals(description_);
  frames_ = sim::link_frames(description_);
  sensor_ports_ = sensor_ports(description_);
  first_sensor_port_ = sensors_.size() - sensor_ports_.size();  // the sensors' ports come last
  std::size_t offset = 0;
  for (const auto& s : description_.sensors) sensor_offset_.push_back(offset), offset += sensor_values(s.kind);
}

void JointWorld::command(std::size_t i, const double* v, std::size_t n) {
  interfaces_.command(i, n == 1 ? v[0] : std::numeric_limits<double>::quiet_NaN());
}

void JointWorld::step() {
  interfaces_.begin_step(state_, tick_);
  advance();
  interfaces_.end_step();
  ++tick_;
}

void JointWorld::sensor(std::size_t i, double* out) const {
  const std::size_t joint_ports = 3 * state_.size();
  if (i < joint_ports) {
    const JointState& s = state_[i / 3];
    out[0] = i % 3 == 0 ? s.position : i % 3 == 1 ? s.velocity : s.effort;
    return;
  }
  if (i >= first_sensor_port_) {
    if (readings_tick_ != tick_) read_sensors(readings_), readings_tick_ = tick_;
    const SensorPort& p = sensor_ports_[i - first_sensor_port_];
    std::copy_n(readings_.begin() + static_cast<std::ptrdiff_t>(sensor_offset_[p.sensor] + p.offset), p.size, out);
    return;
  }
  if (sensors_[i].name == "links.frames") return link_frames(out);
  const bool clamps = i == joint_ports;
  for (std::size_t k = 0; k < interfaces_.inputs(); ++k) {
    const InputCounts& c = interfaces_.counts(k);
    out[k] = static_cast<double>(clamps ? c.clamped : c.stale);
  }
}

void JointWorld::status(StatusSink& sink) const {
  std::vector<std::pair<std::string, double>> q, clamped, stale, samples;
  std::vector<double> clamps_vec, stale_vec;  // as the outputs safety.clamps and safety.stale hold them
  for (std::size_t j = 0; j < state_.size(); ++j) q.emplace_back(description_.joints[j].name, state_[j].position);
  for (std::size_t k = 0; k < interfaces_.inputs(); ++k) {
    const InputCounts& c = interfaces_.counts(k);
    samples.emplace_back(interfaces_.input_name(k), static_cast<double>(c.samples));
    clamped.emplace_back(interfaces_.input_name(k), static_cast<double>(c.clamped));
    stale.emplace_back(interfaces_.input_name(k), static_cast<double>(c.stale));
    clamps_vec.push_back(static_cast<double>(c.clamped));
    stale_vec.push_back(static_cast<double>(c.stale));
  }
  sink.table("joint_position", q);
  sink.table("command_samples", samples);
  sink.table("clamped", clamped);
  sink.table("stale", stale);
  if (interfaces_.inputs() > 0) sink.numbers("safety_clamps", clamps_vec), sink.numbers("safety_stale", stale_vec);
  sink.texts("warnings", description_.warnings);
  sink.texts("world_summary", summary());
  more_status(sink);
}

std::string JointWorld::describe() const {
  std::size_t moving = description_.joints.size();
  return kind() + " of robot '" + description_.name + "' (" + description_.urdf.file + "), " + std::to_string(moving) +
         " moving joints, " + std::to_string(interfaces_.inputs()) + " command inputs" +
         (description_.declared ? "" : " (none declared: effort on every joint)");
}

std::vector<std::string> JointWorld::summary() const {
  std::vector<std::string> lines;
  for (std::size_t k = 0; k < interfaces_.inputs(); ++k) {
    const InputCounts& c = interfaces_.counts(k);
    if (c.clamped == 0 && c.stale == 0) continue;
    char line[512];
    std::snprintf(line, sizeof line, "%s: %llu of %llu samples clamped, stale %llu times%s",
                  interfaces_.input_name(k).c_str(), static_cast<unsigned long long>(c.clamped),
                  static_cast<unsigned long long>(c.samples), static_cast<unsigned long long>(c.stale),
                  c.first_stale_tick < 0 ? "" : (" (first at " + std::to_string(c.first_stale_tick * period_) + " s)").c_str());
    lines.emplace_back(line);
  }
  if (lines.empty() && interfaces_.inputs() > 0) lines.emplace_back("safety: no command clamped, no watchdog tripped");
  more_summary(lines);
  return lines;
}

namespace {

// Mock hardware: each joint's state follows its command (through a first-order lag), no dynamics.
class MockWorld final : public JointWorld {
 public:
  MockWorld(RobotDescription d, double period, double lag, const std::vector<std::string>& dead)
      : JointWorld(std::move(d), period), alpha_(lag > 0 ? 1 - std::exp(-period / lag) : 1.0), mock_sensors_(description_) {
    dead_.assign(state_.size(), 0);
    for (const auto& name : dead) {
      const JointSpec* j = description_.joint(name);
      if (!j) throw std::invalid_argument("mock: dead=" + name + ": the robot has no moving joint of that name");
      dead_[static_cast<std::size_t>(j - description_.joints.data())] = 1;
      dead_names_ += (dead_names_.empty() ? "" : ", ") + name;
    }
  }

 private:
  void advance() override {
    const double h = period();
    for (std::size_t j = 0; j < state_.size(); ++j) {
      JointState& s = state_[j];
      const JointDrive& d = interfaces_.drive(j);
      const JointLimitSpec& l = description_.joints[j].limits;
      const double q0 = s.position;
      if (!d.commanded || dead_[j]) {
        s.velocity = s.effort = 0;
        continue;
      }
      switch (d.kind) {
        case JointInterface::position:
          s.position = follow(s.position, d.value);
          s.velocity = (s.position - q0) / h, s.effort = 0;
          break;
        case JointInterface::velocity:
          s.velocity = follow(s.velocity, d.value);
          s.position += s.velocity * h, s.effort = 0;
          break;
        case JointInterface::effort:
          s.effort = follow(s.effort, d.value);
          s.velocity = 0;
          break;
      }
      if (s.position < l.lower || s.position > l.upper) {  // the hard stops
        s.position = std::clamp(s.position, l.lower, l.upper);
        s.velocity = (s.position - q0) / h;
      }
    }
  }
  // One step of the first-order lag from `x` towards `target` (exactly the target without a lag).
  double follow(double x, double target) const { return alpha_ == 1.0 ? target : x + alpha_ * (target - x); }
  std::string kind() const override { return "mock hardware"; }
  // The frames by forward kinematics of the URDF's joint origins and the joints' positions.
  void link_frames(double* out) const override {
    q_.resize(state_.size());
    for (std::size_t j = 0; j < state_.size(); ++j) q_[j] = state_[j].position;
    joint_frames(description_, q_, out);
  }
  void read_sensors(std::vector<double>& out) const override { mock_sensors_.read(state_, out); }
  void more_summary(std::vector<std::string>& lines) const override {
    if (!dead_names_.empty()) lines.push_back("mock: dead drives (commands ignored): " + dead_names_);
  }

  double alpha_;
  MockSensors mock_sensors_;
  std::vector<char> dead_;  // per joint: its drive is dead
  std::string dead_names_;
  mutable std::vector<double> q_;  // link_frames' joint positions
};

}  // namespace

std::unique_ptr<JointWorld> make_mock_world(RobotDescription description, double period, double lag,
                                            const std::vector<std::string>& dead) {
  return std::make_unique<MockWorld>(std::move(description), period, lag, dead);
}

std::unique_ptr<JointWorld> make_robot_world(const std::string& spec, double period) {
  RobotWorldSpec s;
  std::string error;
  if (!parse_world_spec(spec, &s, &error)) throw std::invalid_argument(error);
  RobotDescription d = load_description(s.file);
  if (s.mock) return make_mock_world(std::move(d), period, s.lag, s.dead);
  return make_simbody_world(std::move(d), period);
}

}  // namespace dca::sim
