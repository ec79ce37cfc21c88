#pragma once
// JointTrajectory: a joint-trajectory follower for any arm of a URDF world (docs/robots.md, "joint_control").
#include <string>
#include <vector>

#include <Eigen/Core>

#include "joint_group.h"

namespace dca::joint_control {

/// JointTrajectory(host, joints, tolerance=0.01, interface="position", gain=2, timeout=60, period=0.01,
/// waypoints...): moves the joints `joints` names through waypoints, each `t q1 ... qN` (N joints): the setpoint
/// goes from where the joints are to the first waypoint in t1 s, then from each waypoint to the next in the
/// difference of their times, along a minimum-jerk curve (at rest at each waypoint). A waypoint is reached when
/// every joint is within `tolerance` of it and slower than `tolerance` per second, on two ticks in a row, once
/// its time is up; the next segment starts then. DONE (the seconds it took) at the last; ABORTED, naming the
/// joint furthest off (or the joints that never reported), when not there after `timeout` s. Each run starts
/// with the parameters' waypoints; a sample at the input Waypoints (the same numbers, as a vectorx) replaces them
/// from where the setpoint is, its times counted from its arrival. With none it holds the joints where they are.
/// Through the position command (the setpoint) or the velocity command (the setpoint's velocity plus gain times
/// the error); halt() leaves a position command to the world (which holds it) and writes a zero velocity.
///   in  Q1..Q8, Qd1..Qd8, out Cmd1..Cmd8: the joints' device ports (joint_group.h)
///   in  Waypoints  vectorx  t q1 ... qN, t q1 ... qN, ...
///   out Setpoint   vectorx  the setpoint's positions, per joint
///   out Reached    scalar   how many waypoints have been reached
class JointTrajectory final : public JointGroup {
  DCA_CONTROLLER(JointTrajectory)
  void on_configure() override;
  void MainCalc() override;
  void on_halt() override;

  /// "" when `v` (n numbers) is a trajectory of this leaf's joints, else why not.
  std::string check(const double* v, std::size_t n) const;
  /// Takes a new trajectory (checked) from the setpoint as it is.
  void load(const double* v, std::size_t n);
  /// The setpoint and its velocity at this tick; true when the current waypoint's time is up.
  bool interpolate();
  /// Whether the joints are at the current waypoint (two ticks in a row).
  bool arrived();
  /// Why the run is late: the waypoint and the joint furthest from it.
  std::string late() const;

  In<Eigen::VectorXd> waypoints_in_;
  Out<Eigen::VectorXd> setpoint_out_;
  Out<double> reached_out_;
  double tolerance_, gain_, timeout_;
  bool velocity_ = false, holding_ = false;
  std::vector<double> given_;       // the parameters' waypoints
  std::vector<double> plan_;        // the waypoints followed: (1 + N) numbers each
  std::size_t count_ = 0, next_ = 0;  // waypoints, and the one the setpoint goes to
  Nanos segment_start_ = 0;
  int near_ = 0;
  Eigen::VectorXd from_, setpoint_, velocity_ref_, cmd_, input_;
};

}  // namespace dca::joint_control
