#include "sim/urdf/joint_interfaces.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "sim/urdf/frames.h"
#include "sim/urdf/sensors.h"

namespace dca::sim {
namespace {

const char* units_of(const JointSpec& j, JointInterface k) {
  const bool linear = j.linear;
  switch (k) {
    case JointInterface::position: return linear ? "m" : "rad";
    case JointInterface::velocity: return linear ? "m/s" : "rad/s";
    case JointInterface::effort: return linear ? "N" : "N m";
  }
  return "";
}

std::string command_name(const JointSpec& j, JointInterface k) {
  return "joint." + j.name + "." + to_string(k) + "_command";
}

}  // namespace

std::vector<DeviceSignal> joint_sensor_signals(const RobotDescription& d) {
  std::vector<DeviceSignal> out;
  std::uint32_t inputs = 0;
  for (const auto& j : d.joints) {
    for (const auto k : {JointInterface::position, JointInterface::velocity, JointInterface::effort})
      out.push_back({"joint." + j.name + "." + to_string(k), 1, units_of(j, k)});
    inputs += static_cast<std::uint32_t>(j.commands.size());
  }
  if (inputs > 0) {
    out.push_back({"safety.clamps", inputs, "samples clamped, per command input"});
    out.push_back({"safety.stale", inputs, "watchdog trips, per command input"});
  }
  if (const auto n = link_frames(d).size(); n > 0)
    out.push_back({"links.frames", static_cast<std::uint32_t>(n * frames::kValuesPerFrame),
                   "per link frame: x y z (m), qx qy qz qw, in its parent link"});
  for (auto& s : sensor_signals(d)) out.push_back(std::move(s));
  return out;
}

std::vector<DeviceSignal> joint_command_signals(const RobotDescription& d) {
  std::vector<DeviceSignal> out;
  for (const auto& j : d.joints)
    for (const auto& c : j.commands) out.push_back({command_name(j, c.kind), 1, units_of(j, c.kind)});
  return out;
}

JointInterfaces::JointInterfaces(const RobotDescription& d) : joints_(d.joints) {
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    active_.push_back(joints_[j].commands.empty() ? SIZE_MAX : inputs_.size());
    for (const auto& c : joints_[j].commands) {
      Input in;
      in.name = command_name(joints_[j], c.kind);
      in.joint = j;
      in.spec = &c;
      in.raw = initial_value(in);
      inputs_.push_back(in);
    }
  }
  drives_.resize(joints_.size());
}

double JointInterfaces::initial_value(const Input& in) const {
  return in.spec->kind == JointInterface::position ? joints_[in.joint].initial : 0.0;
}

void JointInterfaces::command(std::size_t i, double value) {
  Input& in = inputs_[i];
  ++in.counts.samples;
  if (!std::isfinite(value)) {  // dropped: the previous command stays in force
    ++in.counts.clamped;
    return;
  }
  in.raw = value;
  in.has_sample = true;
  in.stale = in.gone = in.counted = false;
  in.age = 0;
  active_[in.joint] = i;
}

void JointInterfaces::writer_gone(std::size_t i) {
  inputs_[i].gone = true;
  inputs_[i].has_sample = true;  // its last command (or the initial one) is what goes stale
}

// The soft velocity bounds of ROS's safety controller (k_position pulls the velocity to zero at the soft
// limits), within the joint's velocity limit and the interface's min/max for a velocity interface.
void JointInterfaces::velocity_bounds(const JointLimitSpec& l, const CommandSpec& c, double q, double* lo,
                                      double* hi) const {
  *lo = -l.velocity;
  *hi = l.velocity;
  if (l.soft && l.k_position > 0) {
    *lo = std::max(*lo, -l.k_position * (q - l.soft_lower));
    *hi = std::min(*hi, -l.k_position * (q - l.soft_upper));
  }
  if (c.kind == JointInterface::velocity) *lo = std::max(*lo, c.min), *hi = std::min(*hi, c.max);
  if (*lo > *hi) *lo = *hi = 0.5 * (*lo + *hi);
}

double JointInterfaces::clamp(const Input& in, double v, const JointState& s) const {
  const JointSpec& j = joints_[in.joint];
  const JointLimitSpec& l = j.limits;
  const CommandSpec& c = *in.spec;
  double lo = c.min, hi = c.max;
  switch (c.kind) {
    case JointInterface::position:
      lo = std::max(lo, l.soft ? l.soft_lower : l.lower);
      hi = std::min(hi, l.soft ? l.soft_upper : l.upper);
      break;
    case JointInterface::velocity:
      velocity_bounds(l, c, s.position, &lo, &hi);
      break;
    case JointInterface::effort: {
      lo = std::max(lo, -l.effort);
      hi = std::min(hi, l.effort);
      if (l.soft && l.k_velocity > 0) {  // ROS: the effort that keeps the velocity within its soft bounds
        double vlo = 0, vhi = 0;
        velocity_bounds(l, c, s.position, &vlo, &vhi);
        lo = std::max(lo, -l.k_velocity * (s.velocity - vlo));
        hi = std::min(hi, -l.k_velocity * (s.velocity - vhi));
      }
      break;
    }
  }
  if (lo > hi) lo = hi = 0.5 * (lo + hi);
  return std::clamp(v, lo, hi);
}

void JointInterfaces::estop(bool latched) {
  if (latched == estop_) return;
  estop_ = latched;
  if (latched) return held_.assign(joints_.size(), std::numeric_limits<double>::quiet_NaN());
  for (auto& in : inputs_) {  // released: each keeps its safe value until its next sample
    const double q = held_[in.joint];
    if (in.spec->kind != JointInterface::position) in.raw = 0;
    else if (!std::isnan(q)) in.raw = q;
    in.stale = in.gone = in.counted = false;
    in.age = 0;
  }
}

void JointInterfaces::estop_step(const std::vector<JointState>& state) {
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    JointDrive& d = drives_[j];
    d.commanded = active_[j] != SIZE_MAX;
    if (!d.commanded) continue;
    if (std::isnan(held_[j])) held_[j] = state[j].position;
    d.input = active_[j];
    d.kind = inputs_[d.input].spec->kind;
    d.value = d.kind == JointInterface::position ? held_[j] : 0.0;
  }
}

void JointInterfaces::begin_step(const std::vector<JointState>& state, long tick) {
  if (estop_) return estop_step(state);
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    JointDrive& d = drives_[j];
    d.commanded = active_[j] != SIZE_MAX;
    if (!d.commanded) continue;
    Input& in = inputs_[active_[j]];
    const CommandSpec& c = *in.spec;
    const bool stale = in.gone || (in.has_sample && c.watchdog_ticks > 0 && in.age >= c.watchdog_ticks);
    if (stale && !in.stale) {
      in.stale = true;
      ++in.counts.stale;
      if (in.counts.first_stale_tick < 0) in.counts.first_stale_tick = tick;
      in.zero = c.kind == JointInterface::position ? state[j].position : 0.0;
    }
    const double wanted = in.stale && c.on_stale == OnStale::zero ? in.zero : in.raw;
    d.kind = c.kind;
    d.input = active_[j];
    d.value = clamp(in, wanted, state[j]);
    if (d.value != wanted && in.has_sample && !in.stale && !in.counted) {
      ++in.counts.clamped;
      in.counted = true;
    }
  }
}

void JointInterfaces::end_step() {
  for (auto& in : inputs_)
    if (in.has_sample && !in.gone) ++in.age;
}

}  // namespace dca::sim
