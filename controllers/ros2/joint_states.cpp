#include "joint_states.h"

#include <algorithm>

#include <dca/registry.h>

#include "stamp.h"

namespace dca::ros2 {
namespace {

const Param<std::string> kJoints{
    .name = "joints", .doc = "the joints' names in the URDF, in order, between spaces or commas (at most 8)"};
const Param<std::string> kFrame{.name = "frame", .doc = "header.frame_id of the message", .def = ""};
const OutSpec<msgs::JointState> kOut{.name = "JointState"};

using Vec1 = Eigen::Matrix<double, 1, 1>;

struct StatePorts {
  std::vector<InSpec<Vec1>> q, qd;
};

const StatePorts& state_ports() {
  static const StatePorts ports = [] {
    StatePorts p;
    for (int i = 1; i <= kMaxStateJoints; ++i) {
      const std::string n = std::to_string(i), joint = "joint.{joints[" + n + "]}";
      p.q.push_back({.name = "Q" + n, .units = "rad or m", .device = joint + ".position"});
      p.qd.push_back({.name = "Qd" + n, .units = "rad/s or m/s", .device = joint + ".velocity"});
    }
    return p;
  }();
  return ports;
}

std::vector<std::string> joint_names(const std::string& text) {
  std::vector<std::string> names;
  std::string word;
  for (const char c : text + " ") {
    if (c == ' ' || c == ',' || c == '\t' || c == '\n') {
      if (!word.empty()) names.push_back(word);
      word.clear();
    } else {
      word += c;
    }
  }
  return names;
}

}  // namespace

Manifest JointStates::Describe() {
  Manifest m{.type = "JointStates",
             .doc = "a URDF world's joints as one sensor_msgs/msg/JointState (for /joint_states: docs/ros2.md)",
             .outputs = {kOut},
             .params = {kJoints, kFrame, PeriodParam(0.02)},
             .ends = Ending::Never()};
  m.inputs.insert(m.inputs.end(), state_ports().q.begin(), state_ports().q.end());
  m.inputs.insert(m.inputs.end(), state_ports().qd.begin(), state_ports().qd.end());
  return m;
}

JointStates::JointStates(const ControllerContext& ctx) : PeriodicController(ctx), out_(port(kOut)) {
  const std::vector<std::string> names = joint_names(param(kJoints));
  const std::string given = "parameter 'joints' ('" + param(kJoints) + "')";
  if (names.empty() || names.size() > static_cast<std::size_t>(kMaxStateJoints))
    throw bad_param(given + " names " + std::to_string(names.size()) + " joints: 1 to " +
                    std::to_string(kMaxStateJoints));
  for (const std::string& n : names) {
    msgs::Name name;
    if (!name.assign(n)) throw bad_param(given + ": the name '" + n + "' is longer than 63 bytes");
    if (std::find(msg_.name.begin(), msg_.name.end(), name) != msg_.name.end())
      throw bad_param(given + " names joint '" + n + "' twice");
    msg_.name.push_back(name);
  }
  if (!msg_.header.frame_id.assign(param(kFrame))) throw bad_param("parameter 'frame' is longer than 63 bytes");
  msg_.position.resize(names.size());
  msg_.velocity.resize(names.size());
  for (std::size_t i = 0; i < names.size(); ++i) {
    q_.push_back(port(state_ports().q[i]));
    qd_.push_back(port(state_ports().qd[i]));
  }
  have_.assign(names.size(), 0);
}

void JointStates::on_start(const msgpack::object&) { std::fill(have_.begin(), have_.end(), 0); }

void JointStates::MainCalc() {
  bool all = true;
  for (std::size_t i = 0; i < q_.size(); ++i) {
    if (q_[i].read(sample_) != Read::None) {
      msg_.position[i] = sample_[0];
      have_[i] = 1;
    }
    if (qd_[i].read(sample_) != Read::None) msg_.velocity[i] = sample_[0];
    all = all && have_[i] != 0;
  }
  if (!all) return;
  msg_.header.stamp = stamp_of(now());
  out_.write(msg_);
}

DCA_REGISTER_CONTROLLER(JointStates);

}  // namespace dca::ros2
