#pragma once
// Serial-chain kinematics read from URDF (the same file the simulator loads): forward kinematics and the
// geometric Jacobian of a chain from a base link to a tip link, and the whole-body Jacobian of an arm on a
// holonomic base (x, y, yaw). Eigen only; no Simbody, no Lua.
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

namespace dca::math {

/// Upper bound on the movable joints of a chain (fixed-size storage keeps MainCalc free of allocation).
inline constexpr int kMaxDof = 12;

using JacobianMatrix = Eigen::Matrix<double, 6, Eigen::Dynamic, 0, 6, kMaxDof>;  ///< rows: v (3), w (3)
using JointVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxDof, 1>;

/// One joint of a chain, as URDF gives it.
struct Joint {
  enum class Type { kRevolute, kPrismatic, kFixed };
  std::string name;
  Type type = Type::kFixed;
  Eigen::Isometry3d origin = Eigen::Isometry3d::Identity();  ///< parent link frame -> joint frame at q = 0
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();           ///< unit axis in the joint frame
  double lower = -1e9, upper = 1e9;                          ///< position limits (rad or m)
};

/// A serial chain base_link -> ... -> tip_link. Movable joints are numbered in order from the base.
class Chain {
 public:
  /// Reads the chain from a URDF file. On failure returns nullopt and sets *error to a message naming the
  /// file and the link or joint ("robot.urdf: no link 'tool'", "robot.urdf: joint 'j7' is planar: ...").
  static std::optional<Chain> FromUrdfFile(const std::string& path, const std::string& base_link,
                                           const std::string& tip_link, std::string* error);
  /// Same, from URDF text; `name` stands for the file in messages.
  static std::optional<Chain> FromUrdfString(const std::string& xml, const std::string& name,
                                             const std::string& base_link, const std::string& tip_link,
                                             std::string* error);
  /// A chain from explicit joints (tests, synthetic arms).
  explicit Chain(std::vector<Joint> joints);

  int dof() const { return dof_; }
  const std::vector<Joint>& joints() const { return joints_; }
  /// Names of the movable joints, base first.
  std::vector<std::string> joint_names() const;
  double lower(int i) const { return joints_[static_cast<size_t>(movable_[static_cast<size_t>(i)])].lower; }
  double upper(int i) const { return joints_[static_cast<size_t>(movable_[static_cast<size_t>(i)])].upper; }

  /// A fixed transform applied after the tip link (a tool centre point).
  void set_tool(const Eigen::Isometry3d& tool) { tool_ = tool; }

  /// Pose of the tool frame in the base link frame at joint positions q (size dof()). No allocation.
  Eigen::Isometry3d Forward(const JointVector& q) const;
  /// Geometric Jacobian at q: tool-origin linear and angular velocity, in the base link frame. No allocation.
  void Jacobian(const JointVector& q, JacobianMatrix* J) const;

 private:
  std::vector<Joint> joints_;
  std::vector<int> movable_;
  int dof_ = 0;
  Eigen::Isometry3d tool_ = Eigen::Isometry3d::Identity();
};

/// Planar pose of a holonomic base in the world: x, y (m), yaw (rad).
struct BasePose {
  double x = 0, y = 0, yaw = 0;
  Eigen::Isometry3d ToIsometry() const;
};

/// Whole-body Jacobian of an arm on a holonomic base: columns (base vx, vy, yaw rate in the world frame, then
/// the arm's joints), rows the tool's linear and angular velocity in the world frame. `arm` is the chain
/// from the base link (whose frame is the planar base pose) to the tool. No allocation.
void MobileJacobian(const BasePose& base, const Chain& arm, const JointVector& q, JacobianMatrix* J);

/// The tool pose in the world for a base pose and arm joints.
Eigen::Isometry3d MobileForward(const BasePose& base, const Chain& arm, const JointVector& q);

}  // namespace dca::math
