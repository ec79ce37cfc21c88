#pragma once
// The controller library of the paper's door-opening system (section 5, figures 2-6, appendix A).
//
// Signals shared by these controllers:
//   Vel     vector[9]  a motion command in the robot's base frame: a tool0 twist (vx, vy, vz in m/s, wx, wy, wz
//                      in rad/s) *on top of* the motion that the command's base velocity (vx, vy in m/s, yaw
//                      rate in rad/s, the last three) gives the whole robot. RedundancyResolution drives the base
//                      at that velocity and spreads the extra twist over base and arm. So [0, b] moves the robot
//                      rigidly, [t, 0] moves the tool by t, and [-b_lin, 0, b] moves the base under a still tool.
//   Joints  vector[6]  the arm's joint angles (rad), Puma 560 order, as arm.q of the world.
//   Wrench  vector[6]  force (N) and torque (N m) the tool exerts on the wrist sensor, sensor frame.
//   Pose    vector[3]  the base's pose in the world: x, y (m), yaw (rad).
//   Feature vector[3]  the handle's grasp point in the camera image: u, v (pixels), visible (1/0).
//
// Hardware-facing controllers (XR4000Ctrl, XR4000Odometry, Puma560Ctrl, Puma560Joints, ForceTorque,
// LaserSensor, HandleCamera, GripperControl) reach the robot through *device ports*: ports whose PortSpec names
// a signal of the robot process (`dca sim`, or a real robot's driver process registered as "world"). The
// supervisor that owns the controller connects its device ports to those signals when it connects its group,
// always active. Everything else reaches its inputs through the .dca file's connections.
//
// Every controller here runs periodically (parameter `period`, default 10 ms: in the distributed lock-step each
// tick costs a round trip per node, and every connection delays a sample by one tick, which the gains here are
// tuned for) and its MainCalc allocates nothing. The drives (XR4000Ctrl, Puma560Ctrl, RedundancyResolution) use
// a command while it is younger than `hold` (default 0.01 s, the period of the controllers that command them),
// then count it as zero: at 10 ms a command not refreshed since the previous tick is zero, and a drive faster
// than its source (MotionControl at 1 ms) holds each sample until the next one is due. A crashed or stopped
// source leaves the robot still within `hold`. Stop() writes zero to every actuator.
#include <Eigen/Core>
#include <optional>

#include "controllers/controller.h"
#include "controllers/hinge_estimator.h"
#include "controllers/kinematics.h"
#include "controllers/redundancy.h"

namespace dca::door {

using Vec3 = Eigen::Matrix<double, 3, 1>;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Vec9 = Eigen::Matrix<double, 9, 1>;

/// The robot's URDF (the file `dca sim` loads): $DCA_MODELS_DIR/mobile_manipulator.urdf, else the installed or
/// source tree's sim/models/.
std::string robot_urdf_path();
/// The arm chain base_link -> tool0 of the robot's URDF. Throws std::invalid_argument naming the file.
kin::Chain robot_arm();
/// The camera's pose (camera_link: x along the optical axis, y left, z up) in base_link, from the robot's URDF.
/// Throws std::invalid_argument naming the file.
Eigen::Isometry3d robot_camera();

/// Reads the newest sample of `in` into `v` when one arrived since the last call. Returns whether one did.
template <int N>
bool fresh(Input& in, Eigen::Matrix<double, N, 1>& v) {
  if (!in.take_latest()) return false;
  const auto s = in.vector();
  if (s.size() != N) return false;
  v = s;
  return true;
}

/// A drive's command: the newest sample of its input, used for `hold` after it arrived, then zero (a deadman).
template <int N>
class HeldCommand {
 public:
  using Vec = Eigen::Matrix<double, N, 1>;
  explicit HeldCommand(double hold_s) : hold_(static_cast<Nanos>(hold_s * 1e9)) {}
  /// The command at `now`: a sample that arrived since the last call, else the last one while it is younger
  /// than `hold`, else zero.
  const Vec& update(Input& in, Nanos now) {
    if (fresh(in, v_)) at_ = now;
    else if (at_ < 0 || now - at_ >= hold_) v_.setZero();
    return v_;
  }
  /// Forgets the last command (Run: a new run starts from zero).
  void reset() {
    v_.setZero();
    at_ = -1;
  }

 private:
  Nanos hold_;
  Nanos at_ = -1;
  Vec v_ = Vec::Zero();
};

// ------------------------------------------------------------------------------------------ hardware-facing

/// XR4000Ctrl(host, period=0.01, hold=0.01): the base's velocity drive.
///   in  Vel     vector[3] base velocity command (m/s, m/s, rad/s), zero once `hold` s old (HeldCommand)
///   out Cmd     vector[3] device base.cmd_vel
class XR4000Ctrl final : public Controller {
 public:
  static Manifest Describe();
  explicit XR4000Ctrl(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;
  void Stop() override;

 private:
  Input& vel_;
  Output& cmd_;
  double period_;
  HeldCommand<3> v_;
};

/// XR4000Odometry(host, period=0.01): the base's odometry.
///   in  Odom    vector[3] device base.pose
///   out Pose    vector[3] x, y (m), yaw (rad) in the world
class XR4000Odometry final : public Controller {
 public:
  static Manifest Describe();
  explicit XR4000Odometry(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;

 private:
  Input& odom_;
  Output& pose_;
  double period_;
  Vec3 p_ = Vec3::Zero();
};

/// Puma560Ctrl(host, period=0.01, hold=0.01): the arm's joint-velocity drive, which also publishes the joint
/// angles.
///   in  Vel     vector[6] joint velocity command (rad/s), zero once `hold` s old (HeldCommand)
///   in  Q       vector[6] device arm.q
///   out Cmd     vector[6] device arm.cmd_qd
///   out Joints  vector[6] joint angles (rad)
class Puma560Ctrl final : public Controller {
 public:
  static Manifest Describe();
  explicit Puma560Ctrl(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;
  void Stop() override;

 private:
  Input &vel_, &q_in_;
  Output &cmd_, &joints_;
  double period_;
  HeldCommand<6> v_;
  Vec6 q_ = Vec6::Zero();
};

/// Puma560Joints(host, period=0.01): the arm's joint angles.
///   in  Q       vector[6] device arm.q
///   out Joints  vector[6] joint angles (rad)
class Puma560Joints final : public Controller {
 public:
  static Manifest Describe();
  explicit Puma560Joints(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;

 private:
  Input& q_in_;
  Output& joints_;
  double period_;
  Vec6 q_ = Vec6::Zero();
};

/// ForceTorque(host, period=0.01): the wrist force/torque sensor.
///   in  Raw     vector[6] device wrist.wrench
///   out Wrench  vector[6] N, N m (sensor frame)
class ForceTorque final : public Controller {
 public:
  static Manifest Describe();
  explicit ForceTorque(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;

 private:
  Input& raw_;
  Output& wrench_;
  double period_;
  Vec6 w_ = Vec6::Zero();
};

/// LaserSensor(host, period=0.01): the laser range finder facing forward from the base.
///   in  Raw       vector[1] device laser.range
///   out Distance  scalar    m to the door's plane
class LaserSensor final : public Controller {
 public:
  static Manifest Describe();
  explicit LaserSensor(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;

 private:
  Input& raw_;
  Output& distance_;
  double period_;
};

/// HandleCamera(host, period=0.01): the camera's handle-feature tracker.
///   in  Raw      vector[3] device camera.handle
///   out Feature  vector[3] u, v (pixels), visible (1/0)
class HandleCamera final : public Controller {
 public:
  static Manifest Describe();
  explicit HandleCamera(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;

 private:
  Input& raw_;
  Output& feature_;
  double period_;
  Vec3 f_ = Vec3::Zero();
};

/// GripperControl(host, "open"|"close", timeout=3, period=0.01): opens or closes the gripper; DONE when it
/// is open, or when it holds something ("close"); ABORTED when it closed on nothing or the timeout passed.
///   in  State  vector[1] device gripper.state (0 open, 1 closed on nothing, 2 moving, 3 grasping)
///   out Cmd    vector[1] device gripper.cmd (0 open, 1 close)
class GripperControl final : public Controller {
 public:
  static Manifest Describe();
  explicit GripperControl(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;

 private:
  Input& state_in_;
  Output& cmd_;
  bool close_;
  double timeout_, period_;
  Nanos started_ = 0;
  bool seen_moving_ = false;
  Eigen::Matrix<double, 1, 1> cmd_value_;
};

// ------------------------------------------------------------------------------------------------ algorithms

/// RedundancyResolution(host, base_weight=10, arm_weight=1, damping=0.02, period=0.01, hold=0.01): distributes the
/// commanded tool twist over the base's 3 and the arm's 6 joints (weighted, damped least squares, joint-limit
/// avoidance in the null space), after applying the command's own base velocity.
///   in  In       vector[9] Vel (see the header), zero once `hold` s old (HeldCommand)
///   in  Joints   vector[6] arm joint angles
///   out BaseVel  vector[3] to XR4000Ctrl
///   out ArmVel   vector[6] to Puma560Ctrl
class RedundancyResolution final : public Controller {
 public:
  static Manifest Describe();
  explicit RedundancyResolution(const ControllerContext& ctx);

  /// The maths of one tick: joint velocities (base 3, arm 6) for command `cmd` at arm angles `q`.
  static void Solve(const kin::Chain& arm, const Vec9& cmd, const Vec6& q, const kin::JointVector& weights,
                    const kin::RedundancyParams& params, Vec3* base, Vec6* arm_qd);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;
  void Stop() override;

 private:
  Input &in_, &joints_;
  Output &base_out_, &arm_out_;
  kin::Chain arm_;
  kin::JointVector weights_;
  kin::RedundancyParams params_;
  double period_;
  HeldCommand<9> cmd_;
  Vec6 q_ = Vec6::Zero();
  bool have_q_ = false;
};

/// AddVelocity(host, period=0.01): Out = In1 + In2 + In3 (Vel signals; an input not refreshed counts zero).
class AddVelocity final : public Controller {
 public:
  static Manifest Describe();
  explicit AddVelocity(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;

 private:
  Input *in_[3];
  Output& out_;
  double period_;
  Vec9 v_[3];
};

/// VisualServoing(host, speed=0.25, gain=1.5, hfov=1.0472, width=640, lost=0.5, height=480, handle_height=1,
/// lateral=-0.075, period=0.01): drives the robot towards the handle (servoing on one point feature). The handle's
/// image point and its known height above the floor (`handle_height`, m) give its position in the base frame
/// (the camera's pose comes from the robot's URDF); the robot moves forward at `speed` and turns so that the line
/// straight ahead of the base at `lateral` m (where the gripper is: the approach that follows moves the tool
/// straight ahead) passes through the handle. When the feature's ray does not reach that height it turns to
/// centre the handle in the image instead.
///   in  Feature  vector[3] from HandleCamera
///   out Vel      vector[9] the whole robot moves rigidly (base velocity only)
/// ABORTED when the handle has not been visible for `lost` seconds.
class VisualServoing final : public Controller {
 public:
  static Manifest Describe();
  explicit VisualServoing(const ControllerContext& ctx);
  /// The command for a feature at column u: forward at `speed`, turning to centre u.
  static Vec9 Law(double u, double speed, double gain, double focal_px, double centre_u);
  /// Where the handle is in the base frame (x, y), from its image point (u, v), the camera's pose in the base
  /// frame (x along the optical axis, y left, z up), the focal length and image centre in pixels and the
  /// handle's height above the floor; nothing when the pixel's ray does not go down to that height ahead.
  static std::optional<Eigen::Vector2d> Locate(double u, double v, const Eigen::Isometry3d& camera, double focal_px,
                                               double centre_u, double centre_v, double height);
  /// The command for a handle at `handle` (base frame): forward at `speed`, turning (gain 1/s) so that the line
  /// y = `lateral` ahead of the base passes through it.
  static Vec9 Steer(const Eigen::Vector2d& handle, double lateral, double speed, double gain);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;
  void Stop() override;

 private:
  Input& feature_;
  Output& vel_;
  double speed_, gain_, focal_, centre_u_, centre_v_, lost_, handle_height_, lateral_, period_;
  Eigen::Isometry3d camera_ = Eigen::Isometry3d::Identity();
  Vec3 f_ = Vec3::Zero();
  Nanos last_seen_ = 0;
  Vec9 v_ = Vec9::Zero();
};

/// DistanceThreshold(host, distance=0.7, period=0.01): DONE(distance) when Distance <= `distance` (m).
class DistanceThreshold final : public Controller {
 public:
  static Manifest Describe();
  explicit DistanceThreshold(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;

 private:
  Input& distance_;
  double level_, period_;
};

/// ForceThreshold(host, force=6, samples=3, settle=0.3, period=0.01): DONE(|f - f0|) when the force differs
/// from the one measured at the start of the run (the tool's own weight) by more than `force` N for `samples`
/// ticks in a row. f0 is learnt (smoothed) during the first `settle` seconds, when nothing fires: the step
/// that starts a hit detector often starts with a jolt (the base stopping as the previous step ends).
class ForceThreshold final : public Controller {
 public:
  static Manifest Describe();
  explicit ForceThreshold(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;

 private:
  Input& wrench_;
  double level_, period_, settle_;
  long need_;
  long above_ = 0;
  Nanos started_ = 0;
  bool have_bias_ = false;
  Vec6 w_ = Vec6::Zero();
  Eigen::Vector3d bias_ = Eigen::Vector3d::Zero();
};

/// LinearTrajectory(host, speed=0.05, distance=0.4, period=0.01): moves the tool straight ahead (base x) at
/// `speed` m/s; ABORTED after `distance` m (nothing was hit). Out: Vel.
class LinearTrajectory final : public Controller {
 public:
  static Manifest Describe();
  explicit LinearTrajectory(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;
  void Stop() override;

 private:
  Output& vel_;
  double speed_, distance_, period_;
  Nanos started_ = 0;
  Vec9 v_ = Vec9::Zero();
};

/// PressHandle(host, speed=0.03, force=30, travel=0.02, compliance=0.002, period=0.01): presses the grasped
/// handle down (the tool moves down at `speed`; a horizontal admittance lets it follow the lever's arc) until
/// the vertical force (beyond the one at the start: the tool's weight) reaches `force` N. DONE(travel) when the
/// tool had moved at least `travel` m down by then; ABORTED "handle jammed: <force> N reached ..." otherwise.
///   in  Wrench  vector[6] ;  in Joints vector[6] ;  out Vel vector[9]
class PressHandle final : public Controller {
 public:
  static Manifest Describe();
  explicit PressHandle(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;
  void Stop() override;

 private:
  Input &wrench_, &joints_;
  Output& vel_;
  kin::Chain arm_;
  double speed_, force_, travel_, compliance_, period_;
  Vec6 w_ = Vec6::Zero(), q_ = Vec6::Zero();
  bool have_start_ = false, have_bias_ = false;
  double z0_ = 0;
  Eigen::Vector3d bias_ = Eigen::Vector3d::Zero();
  Vec9 v_ = Vec9::Zero();
};

/// CompliantCtrl(host, compliance=0.001, deadband=1, max_speed=0.1, period=0.01): an admittance in the floor
/// plane: the tool moves along the horizontal force it feels (in the base frame, where the tool's weight has no
/// horizontal part; beyond `deadband` N, at most `max_speed`), so the closed chain through the door stays free of
/// large internal forces. Vertically it holds still (the handle stays pressed).  in Wrench, Joints ; out Vel.
class CompliantCtrl final : public Controller {
 public:
  static Manifest Describe();
  explicit CompliantCtrl(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;
  void Stop() override;

 private:
  Input &wrench_, &joints_;
  Output& vel_;
  kin::Chain arm_;
  double compliance_, deadband_, max_speed_, period_;
  Vec6 w_ = Vec6::Zero(), q_ = Vec6::Zero();
  bool have_q_ = false, have_w_ = false;
  Vec9 v_ = Vec9::Zero();
};

/// ModelBasedCtrl(host, speed=0.15, angle=75, radius=0.75, side="right", min_arc=0.1, period=0.01): estimates
/// the hinge and the door's radius online from the hand's path (HingeEstimator) and moves the hand along the
/// circle, pushing the door open. Until the hand has swept `min_arc` rad, or while the fitted radius is not
/// within [0.5, 2] x `radius`, the circle is the guess: a hinge `radius` m to the `side` of the hand in the door's
/// plane (across the robot's heading at the start). DONE(angle in degrees) when the opening measured on the
/// fitted circle reaches `angle` degrees.
///   in  BasePose vector[3] ;  in Joints vector[6] ;  out Vel vector[9]
class ModelBasedCtrl final : public Controller {
 public:
  static Manifest Describe();
  explicit ModelBasedCtrl(const ControllerContext& ctx);
  /// Whether a fit is to be trusted: fitted, with a radius within [0.5, 2] x the guess.
  static bool Plausible(const kin::HingeEstimator& e, double prior_radius);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;
  void Stop() override;

 private:
  Input &pose_, &joints_;
  Output& vel_;
  kin::Chain arm_;
  double speed_, target_, radius_, min_arc_, side_, period_;
  Vec3 base_ = Vec3::Zero();
  Vec6 q_ = Vec6::Zero();
  bool have_pose_ = false, have_q_ = false, started_ = false;
  std::optional<kin::HingeEstimator> est_;
  Eigen::Vector2d start_ = Eigen::Vector2d::Zero(), push_ = Eigen::Vector2d::Zero(),
                  prior_centre_ = Eigen::Vector2d::Zero();
  Vec9 v_ = Vec9::Zero();
};

/// ConfigCtrl(host, reach=0.55, gain=1.5, max_speed=0.2, period=0.01): keeps the arm away from singular,
/// stretched or folded configurations by moving the base under the still tool so that the tool stays `reach` m
/// ahead of the shoulder axis and straight in front of it.  in Joints ; out Vel.
class ConfigCtrl final : public Controller {
 public:
  static Manifest Describe();
  explicit ConfigCtrl(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;
  void Stop() override;

 private:
  Input& joints_;
  Output& vel_;
  kin::Chain arm_;
  double reach_, gain_, max_speed_, period_;
  Vec6 q_ = Vec6::Zero();
  bool have_q_ = false;
  Vec9 v_ = Vec9::Zero();
};

}  // namespace dca::door
