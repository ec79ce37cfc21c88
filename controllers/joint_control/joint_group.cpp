#include "joint_group.h"

#include <algorithm>

namespace dca::joint_control {

std::vector<std::string> split_words(std::string_view text) {
  std::vector<std::string> words;
  std::size_t i = 0;
  const auto gap = [](char c) { return c == ' ' || c == '\t' || c == '\n' || c == ','; };
  while (i < text.size()) {
    while (i < text.size() && gap(text[i])) ++i;
    std::size_t j = i;
    while (j < text.size() && !gap(text[j])) ++j;
    if (j > i) words.emplace_back(text.substr(i, j - i));
    i = j;
  }
  return words;
}

const Param<std::string>& joints_param() {
  static const Param<std::string> p{
      .name = "joints", .doc = "the joints' names in the URDF, in order, between spaces or commas (at most 8)"};
  return p;
}

namespace {
Slots make_slots(bool actuator) {
  Slots s;
  for (int i = 1; i <= kMaxJoints; ++i) {
    const std::string n = std::to_string(i), word = "{joints[" + n + "]}";
    s.q.push_back({.name = "Q" + n, .units = "rad or m", .device = "joint." + word + ".position"});
    s.qd.push_back({.name = "Qd" + n, .units = "rad/s or m/s", .device = "joint." + word + ".velocity"});
    s.cmd.push_back({.name = "Cmd" + n, .units = "the interface's: rad, rad/s, N m (or m, m/s, N)",
                     .device = "joint." + word + ".{interface}_command", .actuator = actuator});
  }
  return s;
}
}  // namespace

const Slots& slots(bool actuator) {
  static const Slots with = make_slots(true), without = make_slots(false);
  return actuator ? with : without;
}

JointGroup::JointGroup(const ControllerContext& ctx, const Slots& slots)
    : PeriodicController(ctx), names_(split_words(param(joints_param()))) {
  const std::string given = "parameter 'joints' ('" + text(joints_param()) + "')";
  if (names_.empty()) throw bad_param(given + " names no joint");
  if (size() > kMaxJoints)
    throw bad_param(given + " names " + std::to_string(size()) + " joints: at most " + std::to_string(kMaxJoints) +
                    " (give the others to another leaf)");
  for (std::size_t i = 0; i < names_.size(); ++i)
    if (std::find(names_.begin(), names_.begin() + static_cast<std::ptrdiff_t>(i), names_[i]) !=
        names_.begin() + static_cast<std::ptrdiff_t>(i))
      throw bad_param(given + " names joint '" + names_[i] + "' twice");
  for (int i = 0; i < kMaxJoints; ++i) {
    q_in_.push_back(port(slots.q[static_cast<std::size_t>(i)]));
    qd_in_.push_back(port(slots.qd[static_cast<std::size_t>(i)]));
    cmd_.push_back(port(slots.cmd[static_cast<std::size_t>(i)]));
  }
  q_ = Eigen::VectorXd::Zero(size());
  qd_ = Eigen::VectorXd::Zero(size());
  have_.assign(names_.size(), 0);
}

bool JointGroup::read_state() {
  bool all = true;
  for (int i = 0; i < size(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (q_in_[k].read(sample_) != Read::None) {
      q_(i) = sample_[0];
      have_[k] = 1;
    }
    if (qd_in_[k].read(sample_) != Read::None) qd_(i) = sample_[0];
    all = all && have_[k] != 0;
  }
  return all;
}

void JointGroup::command(const Eigen::VectorXd& u) {
  for (int i = 0; i < size(); ++i) {
    sample_[0] = u(i);
    cmd_[static_cast<std::size_t>(i)].write(sample_);
  }
}

void JointGroup::reset_state() {
  std::fill(have_.begin(), have_.end(), 0);
  qd_.setZero();
}

std::string JointGroup::silent() const {
  std::string list;
  for (std::size_t i = 0; i < names_.size(); ++i)
    if (have_[i] == 0) list += (list.empty() ? "" : ", ") + names_[i];
  return list;
}

}  // namespace dca::joint_control
