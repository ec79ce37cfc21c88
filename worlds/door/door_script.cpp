#include "worlds/door/door_script.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace dca::sim {
namespace {

constexpr double kPreGraspGap = 0.08;   // m in front of the grasp point
constexpr double kApproachSpeed = 0.03; // m/s
constexpr double kHitForce = 5.0;       // N above the free reading
constexpr double kPressSpeed = 0.04;    // m/s of the grasp point
constexpr double kPushSpeed = 0.12;     // m/s of the grasp point along the door's arc
// The stop pose puts the grasp point here in the base frame (laser ~0.7 m from the door).
const Eigen::Vector2d kGraspInBase(0.935, -0.075);

// The desired tool orientation: approach (z) along the door's normal, fingers (y) vertical.
Eigen::Matrix3d tool_orientation(const Eigen::Vector3d& normal) {
  Eigen::Matrix3d R;
  R.col(2) = normal.normalized();
  R.col(1) = Eigen::Vector3d::UnitZ();
  R.col(0) = R.col(1).cross(R.col(2));
  return R;
}

// Joint rates that move the tool with `twist` (angular; linear, world frame): damped least squares.
std::array<double, 6> arm_rates(const World& w, const Eigen::Matrix<double, 6, 1>& twist) {
  const Eigen::Matrix<double, 6, 6> J = w.tool_jacobian();
  const Eigen::Matrix<double, 6, 6> A = J * J.transpose() + 1e-4 * Eigen::Matrix<double, 6, 6>::Identity();
  const Eigen::Matrix<double, 6, 1> qd = J.transpose() * A.ldlt().solve(twist);
  std::array<double, 6> out{};
  for (int i = 0; i < 6; ++i) out[static_cast<size_t>(i)] = std::clamp(qd(i), -1.0, 1.0);
  return out;
}

// A twist holding orientation R_d and moving with v (plus a pull towards p_d if given).
Eigen::Matrix<double, 6, 1> twist_to(const Eigen::Isometry3d& T, const Eigen::Matrix3d& R_d,
                                     const Eigen::Vector3d& v) {
  const Eigen::AngleAxisd e(R_d * T.linear().transpose());
  Eigen::Matrix<double, 6, 1> tw;
  tw << 2.0 * e.angle() * e.axis(), v;
  return tw;
}

std::array<double, 3> base_frame(const Pose2& base, const Eigen::Vector2d& v_world, double wz) {
  const double c = std::cos(base.yaw), s = std::sin(base.yaw);
  return {c * v_world.x() + s * v_world.y(), -s * v_world.x() + c * v_world.y(), wz};
}

}  // namespace

const char* to_string(DoorPhase p) {
  switch (p) {
    case DoorPhase::drive: return "drive";
    case DoorPhase::pregrasp: return "pregrasp";
    case DoorPhase::approach: return "approach";
    case DoorPhase::close: return "close";
    case DoorPhase::press: return "press";
    case DoorPhase::push: return "push";
    case DoorPhase::done: return "done";
    case DoorPhase::failed: return "failed";
  }
  return "?";
}

ScriptedDoorOpening::ScriptedDoorOpening(double target_angle) : target_(target_angle) {}

void ScriptedDoorOpening::enter(DoorPhase p, double t) {
  phase_ = p;
  start_[static_cast<int>(p)] = t;
  settled_ = 0;
}

void ScriptedDoorOpening::fail(const std::string& why, double t) {
  failure_ = std::string(to_string(phase_)) + ": " + why;
  enter(DoorPhase::failed, t);
}

Commands ScriptedDoorOpening::update(const World& w) {
  const Sensors& s = w.sensors();
  const double t = s.time;
  Commands c;
  const Eigen::Isometry3d door = w.link_pose("door_frame"), grasp = w.link_pose("door_grasp");
  const Eigen::Vector3d normal = door.linear().col(0);  // push direction, horizontal
  const Eigen::Isometry3d tool = w.link_pose("tool0");
  const Eigen::Matrix3d R_d = tool_orientation(normal);
  const double door_yaw = std::atan2(normal.y(), normal.x());
  c.gripper_close = phase_ == DoorPhase::close || phase_ == DoorPhase::press || phase_ == DoorPhase::push ||
                    phase_ == DoorPhase::done;
  if (t - start_[static_cast<int>(phase_)] > 30.0 && phase_ != DoorPhase::done && phase_ != DoorPhase::failed) {
    fail("timed out after 30 s", t);
    return {};
  }
  switch (phase_) {
    case DoorPhase::drive: {
      // Base to the stop pose: facing the door, the grasp point at kGraspInBase.
      const Eigen::Rotation2Dd R(door_yaw);
      const Eigen::Vector2d target = grasp.translation().head<2>() - R * kGraspInBase;
      const Eigen::Vector2d e = target - Eigen::Vector2d(s.base_pose.x, s.base_pose.y);
      const double eyaw = std::remainder(door_yaw - s.base_pose.yaw, 2 * M_PI);
      Eigen::Vector2d v = 1.0 * e;
      if (v.norm() > 0.3) v *= 0.3 / v.norm();
      c.base_vel = base_frame(s.base_pose, v, std::clamp(1.5 * eyaw, -0.4, 0.4));
      if (e.norm() < 0.003 && std::abs(eyaw) < 0.005) ++settled_;
      if (settled_ > 200) enter(DoorPhase::pregrasp, t);
      break;
    }
    case DoorPhase::pregrasp: {
      const Eigen::Vector3d p_d = grasp.translation() - kPreGraspGap * normal;
      const Eigen::Vector3d e = p_d - tool.translation();
      Eigen::Vector3d v = 2.0 * e;
      if (v.norm() > 0.15) v *= 0.15 / v.norm();
      c.arm_qd = arm_rates(w, twist_to(tool, R_d, v));
      const double erot = Eigen::AngleAxisd(R_d * tool.linear().transpose()).angle();
      if (e.norm() < 0.002 && erot < 0.01) ++settled_;
      if (settled_ > 200) {
        for (int i = 0; i < 3; ++i) free_force_[i] = s.wrench[static_cast<size_t>(i)];
        enter(DoorPhase::approach, t);
      }
      break;
    }
    case DoorPhase::approach: {
      // Straight at the grasp point (corrected sideways), until the wrist feels the handle.
      const Eigen::Vector3d to_grasp = grasp.translation() - tool.translation();
      const Eigen::Vector3d lateral = to_grasp - to_grasp.dot(normal) * normal;
      c.arm_qd = arm_rates(w, twist_to(tool, R_d, kApproachSpeed * normal + 2.0 * lateral));
      const double df = std::hypot(s.wrench[0] - free_force_[0], s.wrench[1] - free_force_[1],
                                   s.wrench[2] - free_force_[2]);
      if (df > kHitForce) {
        c.arm_qd = {};
        enter(DoorPhase::close, t);
        c.gripper_close = true;
      } else if (to_grasp.dot(normal) < -0.03) {
        fail("passed the handle without feeling it", t);
      }
      break;
    }
    case DoorPhase::close:
      if (s.gripper == GripperState::grasping) enter(DoorPhase::press, t);
      else if (s.gripper == GripperState::closed) fail("the gripper closed on nothing", t);
      break;
    case DoorPhase::press: {
      // Turn the handle down: move the grasp point along the handle's arc.
      const Eigen::Isometry3d handle = w.link_pose("door_handle");
      const Eigen::Vector3d r = grasp.translation() - handle.translation();
      const Eigen::Vector3d tangent = handle.linear().col(0).cross(r).normalized();
      c.arm_qd = arm_rates(w, twist_to(tool, R_d, kPressSpeed * tangent));
      if (s.handle_angle > w.config().door.latch_release + 0.1) {
        c.arm_qd = {};
        enter(DoorPhase::push, t);
      }
      break;
    }
    case DoorPhase::push: {
      // Along the door's arc with the base; the arm keeps its pose and the handle pressed.
      const Eigen::Vector3d hinge_axis = -door.linear().col(2);
      const Eigen::Vector3d r = grasp.translation() - door.translation();
      Eigen::Vector3d tangent = hinge_axis.cross(r);
      tangent.z() = 0;
      tangent.normalize();
      const double ramp = std::min(1.0, (t - start_[static_cast<int>(phase_)]) / 0.5);
      c.base_vel = base_frame(s.base_pose, ramp * kPushSpeed * tangent.head<2>(), 0);
      if (s.door_angle >= target_) enter(DoorPhase::done, t);
      break;
    }
    case DoorPhase::done:
    case DoorPhase::failed:
      break;
  }
  return c;
}

}  // namespace dca::sim
