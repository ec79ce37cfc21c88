#pragma once
// The joints of a joint_control controller (docs/robots.md, "joint_control"): a group of up to kMaxJoints joints
// of a URDF world, named by the leaf's argument `joints` ("shoulder_pan_joint shoulder_lift_joint ...", spaces
// or commas between). Slot i has three device ports named after the i-th word, as JointSetpoint's are named
// after its `joint`:
//   in  Q<i>    vector[1] device joint.{joints[i]}.position
//   in  Qd<i>   vector[1] device joint.{joints[i]}.velocity
//   out Cmd<i>  vector[1] device joint.{joints[i]}.{interface}_command
// A slot past the last joint is left unwired by the supervisor (docs/data-plane.md, "Device ports").
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include <dca/controller.h>

namespace dca::joint_control {

/// The most joints one leaf drives (a 7-joint arm on a rail); more: two leaves.
inline constexpr int kMaxJoints = 8;

using Vec1 = Eigen::Matrix<double, 1, 1>;

/// The words of `text` between spaces, tabs and commas (as dca.lang.ports.device_signal splits an argument).
std::vector<std::string> split_words(std::string_view text);

/// The parameter `joints`.
const Param<std::string>& joints_param();

/// The device ports of every slot.
struct Slots {
  std::vector<InSpec<Vec1>> q, qd;
  std::vector<OutSpec<Vec1>> cmd;
};
/// The slots, their commands declared `.actuator` (halt() zeroes them: for velocity and effort commands) or not
/// (a position command, which zero would move).
const Slots& slots(bool actuator);
/// `specs` appended to `list` (a manifest's inputs or outputs).
template <class Spec>
void append(std::vector<PortSpec>& list, const std::vector<Spec>& specs) {
  list.insert(list.end(), specs.begin(), specs.end());
}

/// A periodic controller of the joints its argument `joints` names: reads their states, writes their commands.
class JointGroup : public PeriodicController {
 protected:
  /// Binds the slots' ports; throws std::invalid_argument when `joints` names no joint, more than kMaxJoints, or
  /// one twice.
  JointGroup(const ControllerContext& ctx, const Slots& slots);

  /// The joints' names, in slot order.
  const std::vector<std::string>& joints() const { return names_; }
  /// How many joints.
  int size() const { return static_cast<int>(names_.size()); }
  /// Reads every joint's position and velocity into q_ and qd_: true once each position has had a sample.
  bool read_state();
  /// Writes u(i) to joint i's command.
  void command(const Eigen::VectorXd& u);
  /// Forgets the samples read (before a run).
  void reset_state();
  /// The joints whose position has had no sample yet, e.g. "elbow_joint, wrist_1_joint".
  std::string silent() const;

  Eigen::VectorXd q_, qd_;

 private:
  std::vector<std::string> names_;
  std::vector<In<Vec1>> q_in_, qd_in_;
  std::vector<Out<Vec1>> cmd_;
  std::vector<char> have_;
  Vec1 sample_ = Vec1::Zero();
};

}  // namespace dca::joint_control
