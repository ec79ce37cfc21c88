#include "controllers/door.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>

#include "controllers/registry.h"
#include "host/paths.h"

namespace dca::door {
namespace {

constexpr double kPi = 3.14159265358979323846;

ParamSpec opt(std::string name, std::string type, std::string def, std::string doc) {
  return {std::move(name), std::move(type), std::move(def), false, false, std::move(doc)};
}
ParamSpec period_param() { return opt("period", "number", "0.01", "seconds between ticks"); }
ParamSpec hold_param() {
  return opt("hold", "number", "0.01", "a command older than this (s) counts as zero (a drive's deadman)");
}

PortSpec device(PortSpec p, std::string signal) {
  p.device = std::move(signal);
  return p;
}

double positive(double v, const std::string& what) {
  if (!(v > 0)) throw std::invalid_argument(what + " must be positive, got " + std::to_string(v));
  return v;
}

/// The tool's position in the base frame.
Eigen::Vector3d tool_position(const kin::Chain& arm, const Vec6& q) {
  kin::JointVector jq = q;
  return arm.Forward(jq).translation();
}

}  // namespace

std::string robot_urdf_path() {
  namespace fs = std::filesystem;
  if (const char* env = std::getenv("DCA_MODELS_DIR"); env != nullptr && *env != '\0')
    return (fs::path(env) / "mobile_manipulator.urdf").string();
  // <lua dir> is <prefix>/share/dca/lua (installed) or <source>/lua: the models sit beside it.
  const fs::path lua = dca::lua_dir();
  std::error_code ec;
  for (const fs::path& p : {lua.parent_path() / "models" / "mobile_manipulator.urdf",
                            lua.parent_path() / "sim" / "models" / "mobile_manipulator.urdf"})
    if (fs::exists(p, ec)) return p.string();
  return (lua.parent_path() / "sim" / "models" / "mobile_manipulator.urdf").string();
}

kin::Chain robot_arm() {
  std::string error;
  auto chain = kin::Chain::FromUrdfFile(robot_urdf_path(), "base_link", "tool0", &error);
  if (!chain) throw std::invalid_argument(error);
  if (chain->dof() != 6)
    throw std::invalid_argument(robot_urdf_path() + ": the arm base_link -> tool0 has " +
                                std::to_string(chain->dof()) + " movable joints, expected 6");
  return *chain;
}

Eigen::Isometry3d robot_camera() {
  std::string error;
  auto chain = kin::Chain::FromUrdfFile(robot_urdf_path(), "base_link", "camera_link", &error);
  if (!chain) throw std::invalid_argument(error);
  if (chain->dof() != 0)
    throw std::invalid_argument(robot_urdf_path() + ": the camera base_link -> camera_link has movable joints");
  return chain->Forward(kin::JointVector(0));
}

// ------------------------------------------------------------------------------------------ hardware-facing

Manifest XR4000Ctrl::Describe() {
  return {"XR4000Ctrl", "the base's velocity drive (Nomad XR4000)",
          {vector_port("Vel", 3, "m/s, m/s, rad/s")},
          {device(vector_port("Cmd", 3, "m/s, m/s, rad/s"), "base.cmd_vel")},
          {period_param(), hold_param()}};
}
XR4000Ctrl::XR4000Ctrl(const ControllerContext& ctx)
    : Controller(ctx), vel_(input("Vel")), cmd_(output("Cmd")), period_(positive(number("period"), "period")),
      v_(positive(number("hold"), "hold")) {}
void XR4000Ctrl::Run(const msgpack::object&) {
  v_.reset();
  StartPeriodic(period_);
}
void XR4000Ctrl::MainCalc() { cmd_.write(v_.update(vel_, now())); }
void XR4000Ctrl::Stop() { cmd_.write(Vec3::Zero().eval()); }

Manifest XR4000Odometry::Describe() {
  return {"XR4000Odometry", "the base's odometry (Nomad XR4000)",
          {device(vector_port("Odom", 3, "m, m, rad"), "base.pose")},
          {vector_port("Pose", 3, "m, m, rad")},
          {period_param()}};
}
XR4000Odometry::XR4000Odometry(const ControllerContext& ctx)
    : Controller(ctx), odom_(input("Odom")), pose_(output("Pose")), period_(positive(number("period"), "period")) {}
void XR4000Odometry::Run(const msgpack::object&) { StartPeriodic(period_); }
void XR4000Odometry::MainCalc() {
  if (fresh(odom_, p_)) pose_.write(p_);
}

Manifest Puma560Ctrl::Describe() {
  return {"Puma560Ctrl", "the arm's joint-velocity drive (Puma 560); also publishes the joint angles",
          {vector_port("Vel", 6, "rad/s"), device(vector_port("Q", 6, "rad"), "arm.q")},
          {device(vector_port("Cmd", 6, "rad/s"), "arm.cmd_qd"), vector_port("Joints", 6, "rad")},
          {period_param(), hold_param()}};
}
Puma560Ctrl::Puma560Ctrl(const ControllerContext& ctx)
    : Controller(ctx), vel_(input("Vel")), q_in_(input("Q")), cmd_(output("Cmd")), joints_(output("Joints")),
      period_(positive(number("period"), "period")), v_(positive(number("hold"), "hold")) {}
void Puma560Ctrl::Run(const msgpack::object&) {
  v_.reset();
  StartPeriodic(period_);
}
void Puma560Ctrl::MainCalc() {
  if (fresh(q_in_, q_)) joints_.write(q_);
  cmd_.write(v_.update(vel_, now()));
}
void Puma560Ctrl::Stop() { cmd_.write(Vec6::Zero().eval()); }

Manifest Puma560Joints::Describe() {
  return {"Puma560Joints", "the arm's joint angles (Puma 560)",
          {device(vector_port("Q", 6, "rad"), "arm.q")},
          {vector_port("Joints", 6, "rad")},
          {period_param()}};
}
Puma560Joints::Puma560Joints(const ControllerContext& ctx)
    : Controller(ctx), q_in_(input("Q")), joints_(output("Joints")), period_(positive(number("period"), "period")) {}
void Puma560Joints::Run(const msgpack::object&) { StartPeriodic(period_); }
void Puma560Joints::MainCalc() {
  if (fresh(q_in_, q_)) joints_.write(q_);
}

Manifest ForceTorque::Describe() {
  return {"ForceTorque", "the wrist force/torque sensor",
          {device(vector_port("Raw", 6, "N, N m"), "wrist.wrench")},
          {vector_port("Wrench", 6, "N, N m")},
          {period_param()}};
}
ForceTorque::ForceTorque(const ControllerContext& ctx)
    : Controller(ctx), raw_(input("Raw")), wrench_(output("Wrench")), period_(positive(number("period"), "period")) {}
void ForceTorque::Run(const msgpack::object&) { StartPeriodic(period_); }
void ForceTorque::MainCalc() {
  if (fresh(raw_, w_)) wrench_.write(w_);
}

Manifest LaserSensor::Describe() {
  return {"LaserSensor", "the laser range finder: distance ahead of the base to the door's plane",
          {device(vector_port("Raw", 1, "m"), "laser.range")},
          {scalar_port("Distance", "m")},
          {period_param()}};
}
LaserSensor::LaserSensor(const ControllerContext& ctx)
    : Controller(ctx), raw_(input("Raw")), distance_(output("Distance")),
      period_(positive(number("period"), "period")) {}
void LaserSensor::Run(const msgpack::object&) { StartPeriodic(period_); }
void LaserSensor::MainCalc() {
  if (raw_.take_latest() && raw_.vector().size() == 1) distance_.write(raw_.vector()[0]);
}

Manifest HandleCamera::Describe() {
  return {"HandleCamera", "the camera's tracker of the door handle's grasp point",
          {device(vector_port("Raw", 3, "px, px, 1"), "camera.handle")},
          {vector_port("Feature", 3, "px, px, 1")},
          {period_param()}};
}
HandleCamera::HandleCamera(const ControllerContext& ctx)
    : Controller(ctx), raw_(input("Raw")), feature_(output("Feature")),
      period_(positive(number("period"), "period")) {}
void HandleCamera::Run(const msgpack::object&) { StartPeriodic(period_); }
void HandleCamera::MainCalc() {
  if (fresh(raw_, f_)) feature_.write(f_);
}

Manifest GripperControl::Describe() {
  return {"GripperControl", "opens or closes the gripper; DONE when open, or holding something",
          {device(vector_port("State", 1, "0 open, 1 closed, 2 moving, 3 grasping"), "gripper.state")},
          {device(vector_port("Cmd", 1, "0 open, 1 close"), "gripper.cmd")},
          {{"action", "string", "", true, false, "open or close"},
           opt("timeout", "number", "3", "ABORTED when not done after this many seconds"), period_param()}};
}
GripperControl::GripperControl(const ControllerContext& ctx)
    : Controller(ctx), state_in_(input("State")), cmd_(output("Cmd")),
      timeout_(positive(number("timeout"), "timeout")), period_(positive(number("period"), "period")) {
  const std::string a = text("action");
  if (a != "open" && a != "close")
    throw std::invalid_argument("GripperControl " + name() + ": action must be \"open\" or \"close\", got \"" + a + "\"");
  close_ = a == "close";
  cmd_value_[0] = close_ ? 1.0 : 0.0;
}
void GripperControl::Run(const msgpack::object&) {
  started_ = now();
  seen_moving_ = false;
  cmd_.write(cmd_value_);
  StartPeriodic(period_);
}
void GripperControl::MainCalc() {
  cmd_.write(cmd_value_);
  if (state_in_.take_latest() && state_in_.vector().size() == 1) {
    const int s = static_cast<int>(std::lround(state_in_.vector()[0]));
    if (s == 2) seen_moving_ = true;
    if (!close_ && s == 0) return Done(std::string_view("open"));
    if (close_ && s == 3) return Done(std::string_view("grasping"));
    if (close_ && s == 1) return Abort("the gripper closed on nothing: no handle between the fingers");
  }
  if (to_seconds(now() - started_) > timeout_)
    Abort(std::string("the gripper did not ") + (close_ ? "close" : "open") + " within " + text("timeout") + " s");
}

// ------------------------------------------------------------------------------------------------ algorithms

Manifest RedundancyResolution::Describe() {
  return {"RedundancyResolution",
          "spreads a tool twist over the base (3) and the arm (6): weighted, damped least squares",
          {vector_port("In", 9, "Vel"), vector_port("Joints", 6, "rad")},
          {vector_port("BaseVel", 3, "m/s, m/s, rad/s"), vector_port("ArmVel", 6, "rad/s")},
          {opt("base_weight", "number", "10", "cost of base motion (higher: the arm does more)"),
           opt("arm_weight", "number", "1", "cost of arm motion"),
           opt("damping", "number", "0.02", "least-squares damping near singularities"), period_param(),
           hold_param()}};
}
RedundancyResolution::RedundancyResolution(const ControllerContext& ctx)
    : Controller(ctx), in_(input("In")), joints_(input("Joints")), base_out_(output("BaseVel")),
      arm_out_(output("ArmVel")), arm_(robot_arm()), period_(positive(number("period"), "period")),
      cmd_(positive(number("hold"), "hold")) {
  weights_.resize(9);
  weights_.head<3>().setConstant(positive(number("base_weight"), "base_weight"));
  weights_.tail<6>().setConstant(positive(number("arm_weight"), "arm_weight"));
  params_.damping = number("damping");
}

void RedundancyResolution::Solve(const kin::Chain& arm, const Vec9& cmd, const Vec6& q,
                                 const kin::JointVector& weights, const kin::RedundancyParams& params,
                                 Vec3* base, Vec6* arm_qd) {
  kin::JointVector jq = q;
  kin::JacobianMatrix J;
  kin::MobileJacobian(kin::BasePose{}, arm, jq, &J);
  kin::JointVector qall(9), lo(9), hi(9), qd(9);
  qall.head<3>().setZero();
  qall.tail<6>() = q;
  lo.head<3>().setConstant(-1e9);
  hi.head<3>().setConstant(1e9);
  for (int i = 0; i < 6; ++i) {
    lo[3 + i] = arm.lower(i);
    hi[3 + i] = arm.upper(i);
  }
  const Vec6 twist = cmd.head<6>();
  kin::Resolve(J, twist, weights, qall, lo, hi, params, &qd);
  *base = cmd.tail<3>() + qd.head<3>();
  *arm_qd = qd.tail<6>();
}

void RedundancyResolution::Run(const msgpack::object&) {
  cmd_.reset();
  StartPeriodic(period_);
}
void RedundancyResolution::MainCalc() {
  if (fresh(joints_, q_)) have_q_ = true;
  const Vec9& cmd = cmd_.update(in_, now());
  Vec3 base = Vec3::Zero();
  Vec6 arm = Vec6::Zero();
  if (have_q_ && !cmd.isZero()) Solve(arm_, cmd, q_, weights_, params_, &base, &arm);
  base_out_.write(base);
  arm_out_.write(arm);
}
void RedundancyResolution::Stop() {
  base_out_.write(Vec3::Zero().eval());
  arm_out_.write(Vec6::Zero().eval());
}

Manifest AddVelocity::Describe() {
  return {"AddVelocity", "fuses three velocity commands: Out = In1 + In2 + In3",
          {vector_port("In1", 9, "Vel"), vector_port("In2", 9, "Vel"), vector_port("In3", 9, "Vel")},
          {vector_port("Out", 9, "Vel")},
          {period_param()}};
}
AddVelocity::AddVelocity(const ControllerContext& ctx)
    : Controller(ctx), in_{&input("In1"), &input("In2"), &input("In3")}, out_(output("Out")),
      period_(positive(number("period"), "period")) {}
void AddVelocity::Run(const msgpack::object&) { StartPeriodic(period_); }
void AddVelocity::MainCalc() {
  Vec9 sum = Vec9::Zero();
  for (int i = 0; i < 3; ++i) {
    if (!fresh(*in_[i], v_[i])) v_[i].setZero();
    sum += v_[i];
  }
  out_.write(sum);
}

Manifest VisualServoing::Describe() {
  return {"VisualServoing", "drives the robot towards the handle, lining the gripper up with it in the image",
          {vector_port("Feature", 3, "px, px, 1")},
          {vector_port("Vel", 9, "Vel")},
          {opt("speed", "number", "0.25", "forward speed, m/s"),
           opt("gain", "number", "1.5", "turn rate per radian of bearing error, 1/s"),
           opt("hfov", "number", "1.0471975511965976", "the camera's horizontal field of view, rad"),
           opt("width", "number", "640", "the image's width, px"),
           opt("lost", "number", "0.5", "ABORTED when the handle is not seen for this long, s"),
           opt("height", "number", "480", "the image's height, px"),
           opt("handle_height", "number", "1", "the handle's height above the floor, m"),
           opt("lateral", "number", "-0.075", "the gripper's lateral position in the base frame (left +), m"),
           period_param()}};
}
VisualServoing::VisualServoing(const ControllerContext& ctx)
    : Controller(ctx), feature_(input("Feature")), vel_(output("Vel")), speed_(number("speed")),
      gain_(number("gain")), lost_(positive(number("lost"), "lost")),
      handle_height_(number("handle_height")), lateral_(number("lateral")),
      period_(positive(number("period"), "period")), camera_(robot_camera()) {
  const double width = positive(number("width"), "width");
  focal_ = (width / 2) / std::tan(positive(number("hfov"), "hfov") / 2);
  centre_u_ = width / 2;
  centre_v_ = positive(number("height"), "height") / 2;
}
Vec9 VisualServoing::Law(double u, double speed, double gain, double focal_px, double centre_u) {
  // u grows to the right, which is -y of the base: a handle right of centre needs a negative yaw rate.
  const double bearing = std::atan2(u - centre_u, focal_px);
  Vec9 v = Vec9::Zero();
  v[6] = speed;
  v[8] = -gain * bearing;
  return v;
}
std::optional<Eigen::Vector2d> VisualServoing::Locate(double u, double v, const Eigen::Isometry3d& camera,
                                                      double focal_px, double centre_u, double centre_v,
                                                      double height) {
  // The pixel's ray in the camera frame (u right = -y, v down = -z), then in the base frame.
  const Eigen::Vector3d ray = camera.linear() * Eigen::Vector3d(1, -(u - centre_u) / focal_px, -(v - centre_v) / focal_px);
  const Eigen::Vector3d o = camera.translation();
  if (!(ray.z() < -1e-6) || !(height < o.z())) return std::nullopt;
  const double s = (height - o.z()) / ray.z();
  const Eigen::Vector3d p = o + s * ray;
  if (!(p.x() > 0)) return std::nullopt;
  return Eigen::Vector2d(p.x(), p.y());
}
Vec9 VisualServoing::Steer(const Eigen::Vector2d& handle, double lateral, double speed, double gain) {
  Vec9 v = Vec9::Zero();
  v[6] = speed;
  v[8] = gain * std::atan2(handle.y() - lateral, handle.x());
  return v;
}
void VisualServoing::Run(const msgpack::object&) {
  last_seen_ = now();
  v_.setZero();
  StartPeriodic(period_);
}
void VisualServoing::MainCalc() {
  if (fresh(feature_, f_) && f_[2] > 0.5) {
    last_seen_ = now();
    const auto handle = Locate(f_[0], f_[1], camera_, focal_, centre_u_, centre_v_, handle_height_);
    v_ = handle ? Steer(*handle, lateral_, speed_, gain_) : Law(f_[0], speed_, gain_, focal_, centre_u_);
  } else if (to_seconds(now() - last_seen_) > lost_) {
    vel_.write(Vec9::Zero().eval());
    return Abort("lost sight of the handle for more than " + text("lost") + " s");
  }
  vel_.write(v_);
}
void VisualServoing::Stop() { vel_.write(Vec9::Zero().eval()); }

Manifest DistanceThreshold::Describe() {
  return {"DistanceThreshold", "DONE(distance) when Distance falls to the threshold",
          {scalar_port("Distance", "m")}, {},
          {opt("distance", "number", "0.7", "the threshold, m"), period_param()}};
}
DistanceThreshold::DistanceThreshold(const ControllerContext& ctx)
    : Controller(ctx), distance_(input("Distance")), level_(positive(number("distance"), "distance")),
      period_(positive(number("period"), "period")) {}
void DistanceThreshold::Run(const msgpack::object&) { StartPeriodic(period_); }
void DistanceThreshold::MainCalc() {
  if (distance_.take_latest()) {
    const double d = distance_.scalar();
    if (d <= level_) Done(d);
  }
}

Manifest ForceThreshold::Describe() {
  return {"ForceThreshold", "DONE(|f - f0|) when the force departs from its value at the start",
          {vector_port("Wrench", 6, "N, N m")}, {},
          {opt("force", "number", "6", "the threshold, N"),
           opt("samples", "integer", "3", "consecutive samples above the threshold"),
           opt("settle", "number", "0.3", "s after the start during which f0 is learnt (smoothed) and nothing fires"),
           period_param()}};
}
ForceThreshold::ForceThreshold(const ControllerContext& ctx)
    : Controller(ctx), wrench_(input("Wrench")), level_(positive(number("force"), "force")),
      period_(positive(number("period"), "period")), settle_(number("settle")), need_(integer("samples")) {
  if (need_ < 1) throw std::invalid_argument("ForceThreshold " + name() + ": samples must be at least 1");
  if (!(settle_ >= 0)) throw std::invalid_argument("ForceThreshold " + name() + ": settle must be >= 0 s");
}
void ForceThreshold::Run(const msgpack::object&) {
  above_ = 0;
  have_bias_ = false;
  started_ = now();
  StartPeriodic(period_);
}
// The reference f0 is learnt while the run settles: the step that starts this detector often starts with a
// jolt (the base stopping when the previous step ends, the gripper opening), and a reference taken from one
// sample of that jolt fires at once. It is smoothed over the settle time and frozen after it.
void ForceThreshold::MainCalc() {
  if (!fresh(wrench_, w_)) return;
  const Eigen::Vector3d f = w_.head<3>();
  if (!have_bias_) {
    bias_ = f;
    have_bias_ = true;
  }
  if (to_seconds(now() - started_) < settle_) {
    bias_ += 0.2 * (f - bias_);
    return;
  }
  const double d = (f - bias_).norm();
  above_ = d > level_ ? above_ + 1 : 0;
  if (above_ >= need_) Done(d);
}

Manifest LinearTrajectory::Describe() {
  return {"LinearTrajectory", "moves the tool straight ahead; ABORTED after `distance` m",
          {}, {vector_port("Vel", 9, "Vel")},
          {opt("speed", "number", "0.05", "m/s"), opt("distance", "number", "0.4", "m"), period_param()}};
}
LinearTrajectory::LinearTrajectory(const ControllerContext& ctx)
    : Controller(ctx), vel_(output("Vel")), speed_(positive(number("speed"), "speed")),
      distance_(positive(number("distance"), "distance")), period_(positive(number("period"), "period")) {
  v_[0] = speed_;
}
void LinearTrajectory::Run(const msgpack::object&) {
  started_ = now();
  StartPeriodic(period_);
}
void LinearTrajectory::MainCalc() {
  if (to_seconds(now() - started_) * speed_ > distance_) {
    vel_.write(Vec9::Zero().eval());
    return Abort("moved " + text("distance") + " m without reaching anything");
  }
  vel_.write(v_);
}
void LinearTrajectory::Stop() { vel_.write(Vec9::Zero().eval()); }

Manifest PressHandle::Describe() {
  return {"PressHandle", "presses the grasped handle down, compliantly, until it stops",
          {vector_port("Wrench", 6, "N, N m"), vector_port("Joints", 6, "rad")},
          {vector_port("Vel", 9, "Vel")},
          {opt("speed", "number", "0.03", "downward speed of the tool, m/s"),
           opt("force", "number", "30", "the force (N) at which the handle counts as stopped"),
           opt("travel", "number", "0.02", "the travel (m) the handle must allow before it stops"),
           opt("compliance", "number", "0.002", "horizontal admittance, (m/s)/N"), period_param()}};
}
PressHandle::PressHandle(const ControllerContext& ctx)
    : Controller(ctx), wrench_(input("Wrench")), joints_(input("Joints")), vel_(output("Vel")), arm_(robot_arm()),
      speed_(positive(number("speed"), "speed")), force_(positive(number("force"), "force")),
      travel_(positive(number("travel"), "travel")), compliance_(number("compliance")),
      period_(positive(number("period"), "period")) {}
void PressHandle::Run(const msgpack::object&) {
  have_start_ = have_bias_ = false;
  v_.setZero();
  StartPeriodic(period_);
}
void PressHandle::MainCalc() {
  const bool new_q = fresh(joints_, q_);
  const bool new_w = fresh(wrench_, w_);
  if (!have_start_) {
    if (!new_q) return;
    z0_ = tool_position(arm_, q_).z();
    have_start_ = true;
  }
  kin::JointVector jq = q_;
  const Eigen::Isometry3d tool = arm_.Forward(jq);
  // The wrench in the base frame (tool0 and the sensor share their orientation).
  const Eigen::Vector3d f = tool.linear() * w_.head<3>();
  if (!have_bias_) {
    if (!new_w) return;
    bias_ = f;  // vertically: the tool's weight and whatever the grasp holds
    have_bias_ = true;
  }
  const double travel = z0_ - tool.translation().z();
  // The handle pushes the tool up as it is pressed: the tool feels +z from the lever.
  if (f.z() - bias_.z() >= force_) {
    vel_.write(Vec9::Zero().eval());
    if (travel >= travel_) return Done(travel);
    return Abort("handle jammed: " + text("force") + " N reached after " + std::to_string(travel) +
                 " m of travel (needs " + text("travel") + " m)");
  }
  // Down at `speed`; horizontally the tool gives way to the lever (which swings in the door's plane), and to
  // any push left from the approach.
  v_.setZero();
  v_[0] = compliance_ * f.x();
  v_[1] = compliance_ * f.y();
  v_[2] = -speed_;
  vel_.write(v_);
}
void PressHandle::Stop() { vel_.write(Vec9::Zero().eval()); }

Manifest CompliantCtrl::Describe() {
  return {"CompliantCtrl", "admittance: the tool gives way to the horizontal force it feels",
          {vector_port("Wrench", 6, "N, N m"), vector_port("Joints", 6, "rad")},
          {vector_port("Vel", 9, "Vel")},
          {opt("compliance", "number", "0.001", "(m/s)/N"), opt("deadband", "number", "1", "N"),
           opt("max_speed", "number", "0.1", "m/s"), period_param()}};
}
CompliantCtrl::CompliantCtrl(const ControllerContext& ctx)
    : Controller(ctx), wrench_(input("Wrench")), joints_(input("Joints")), vel_(output("Vel")), arm_(robot_arm()),
      compliance_(number("compliance")), deadband_(number("deadband")),
      max_speed_(positive(number("max_speed"), "max_speed")), period_(positive(number("period"), "period")) {}
void CompliantCtrl::Run(const msgpack::object&) {
  have_q_ = have_w_ = false;
  v_.setZero();
  StartPeriodic(period_);
}
void CompliantCtrl::MainCalc() {
  if (fresh(joints_, q_)) have_q_ = true;
  if (fresh(wrench_, w_)) have_w_ = true;
  v_.setZero();
  if (have_q_ && have_w_) {
    // The force in the base frame (tool0 and the sensor share their orientation); its horizontal part is free of
    // the tool's weight and is what the door and the handle push with.
    kin::JointVector jq = q_;
    const Eigen::Vector3d f3 = arm_.Forward(jq).linear() * w_.head<3>();
    Eigen::Vector2d f(f3.x(), f3.y());
    const double n = f.norm();
    if (n > deadband_) {
      Eigen::Vector2d v = compliance_ * (n - deadband_) / n * f;
      if (v.norm() > max_speed_) v *= max_speed_ / v.norm();
      v_.head<2>() = v;
    }
  }
  vel_.write(v_);
}
void CompliantCtrl::Stop() { vel_.write(Vec9::Zero().eval()); }

Manifest ModelBasedCtrl::Describe() {
  return {"ModelBasedCtrl", "pushes the door open along the circle estimated from the hand's path",
          {vector_port("BasePose", 3, "m, m, rad"), vector_port("Joints", 6, "rad")},
          {vector_port("Vel", 9, "Vel")},
          {opt("speed", "number", "0.15", "the hand's speed along the circle, m/s"),
           opt("angle", "number", "75", "DONE when the door is open this far, degrees"),
           opt("radius", "number", "0.75", "guessed distance from the hand to the hinge, m"),
           opt("side", "string", "right", "the hinge's side seen from the robot: right or left"),
           opt("min_arc", "number", "0.1", "the arc (rad) the hand must sweep before the estimate is used"),
           period_param()}};
}
ModelBasedCtrl::ModelBasedCtrl(const ControllerContext& ctx)
    : Controller(ctx), pose_(input("BasePose")), joints_(input("Joints")), vel_(output("Vel")), arm_(robot_arm()),
      speed_(positive(number("speed"), "speed")), target_(positive(number("angle"), "angle") * kPi / 180),
      radius_(positive(number("radius"), "radius")), min_arc_(positive(number("min_arc"), "min_arc")),
      period_(positive(number("period"), "period")) {
  const std::string side = text("side");
  if (side != "right" && side != "left")
    throw std::invalid_argument("ModelBasedCtrl " + name() + ": side must be right or left, got '" + side + "'");
  side_ = side == "right" ? -1.0 : 1.0;
}
void ModelBasedCtrl::Run(const msgpack::object&) {
  have_pose_ = have_q_ = started_ = false;
  est_.reset();
  v_.setZero();
  StartPeriodic(period_);
}
bool ModelBasedCtrl::Plausible(const kin::HingeEstimator& e, double prior_radius) {
  return e.fitted() && e.radius() > 0.5 * prior_radius && e.radius() < 2.0 * prior_radius;
}
void ModelBasedCtrl::MainCalc() {
  if (fresh(pose_, base_)) have_pose_ = true;
  if (fresh(joints_, q_)) have_q_ = true;
  if (!have_pose_ || !have_q_) {
    vel_.write(v_);
    return;
  }
  const double c = std::cos(base_[2]), s = std::sin(base_[2]);
  const Eigen::Vector3d tool = tool_position(arm_, q_);
  const Eigen::Vector2d hand(base_[0] + c * tool.x() - s * tool.y(), base_[1] + s * tool.x() + c * tool.y());
  if (!started_) {
    // The door's plane is across the robot's heading; the hinge lies `radius` to the `side`.
    start_ = hand;
    push_ = Eigen::Vector2d(c, s);
    const Eigen::Vector2d left(-s, c);
    prior_centre_ = hand + side_ * radius_ * left;
    est_.emplace(prior_centre_, radius_, min_arc_);
    started_ = true;
  }
  est_->Add(hand);
  // The circle: the fitted one once the hand has swept enough arc and the fit is plausible, else the prior.
  const bool fitted = Plausible(*est_, radius_);
  const Eigen::Vector2d centre = fitted ? est_->centre() : prior_centre_;
  // Push direction: the circle's tangent whose sense agrees with the push at the start.
  Eigen::Vector2d r0 = start_ - centre, r = hand - centre;
  Eigen::Vector2d t(-r.y(), r.x());
  if (t.norm() < 1e-9) t = push_;
  t.normalize();
  if (Eigen::Vector2d(-r0.y(), r0.x()).dot(push_) < 0) t = -t;
  if (!fitted && t.dot(push_) < 0.5) t = push_;
  const double opened = std::abs(std::atan2(r0.x() * r.y() - r0.y() * r.x(), r0.dot(r)));
  if (fitted && opened >= target_) {
    vel_.write(Vec9::Zero().eval());
    return Done(opened * 180 / kPi);
  }
  v_.setZero();
  v_[0] = speed_ * (c * t.x() + s * t.y());  // world -> base frame
  v_[1] = speed_ * (-s * t.x() + c * t.y());
  vel_.write(v_);
}
void ModelBasedCtrl::Stop() { vel_.write(Vec9::Zero().eval()); }

Manifest ConfigCtrl::Describe() {
  return {"ConfigCtrl", "moves the base under the tool to keep the arm in a comfortable configuration",
          {vector_port("Joints", 6, "rad")}, {vector_port("Vel", 9, "Vel")},
          {opt("reach", "number", "0.55", "the tool's preferred distance ahead of the shoulder axis, m"),
           opt("gain", "number", "1.5", "1/s"), opt("max_speed", "number", "0.2", "m/s"), period_param()}};
}
ConfigCtrl::ConfigCtrl(const ControllerContext& ctx)
    : Controller(ctx), joints_(input("Joints")), vel_(output("Vel")), arm_(robot_arm()),
      reach_(positive(number("reach"), "reach")), gain_(number("gain")),
      max_speed_(positive(number("max_speed"), "max_speed")), period_(positive(number("period"), "period")) {}
void ConfigCtrl::Run(const msgpack::object&) {
  have_q_ = false;
  v_.setZero();
  StartPeriodic(period_);
}
void ConfigCtrl::MainCalc() {
  if (fresh(joints_, q_)) have_q_ = true;
  v_.setZero();
  if (have_q_) {
    // The shoulder axis is joint 1's: its origin in the base frame is the chain's first joint origin.
    const Eigen::Vector3d shoulder = arm_.joints().front().origin.translation();
    const Eigen::Vector3d tool = tool_position(arm_, q_);
    Eigen::Vector2d err(tool.x() - shoulder.x() - reach_, tool.y() - shoulder.y());
    Eigen::Vector2d b = gain_ * err;
    if (b.norm() > max_speed_) b *= max_speed_ / b.norm();
    v_[6] = b.x();
    v_[7] = b.y();
    v_[0] = -b.x();  // the tool stays where it is: the arm takes the base's motion back
    v_[1] = -b.y();
  }
  vel_.write(v_);
}
void ConfigCtrl::Stop() { vel_.write(Vec9::Zero().eval()); }

DCA_REGISTER_CONTROLLER(XR4000Ctrl);
DCA_REGISTER_CONTROLLER(XR4000Odometry);
DCA_REGISTER_CONTROLLER(Puma560Ctrl);
DCA_REGISTER_CONTROLLER(Puma560Joints);
DCA_REGISTER_CONTROLLER(ForceTorque);
DCA_REGISTER_CONTROLLER(LaserSensor);
DCA_REGISTER_CONTROLLER(HandleCamera);
DCA_REGISTER_CONTROLLER(GripperControl);
DCA_REGISTER_CONTROLLER(RedundancyResolution);
DCA_REGISTER_CONTROLLER(AddVelocity);
DCA_REGISTER_CONTROLLER(VisualServoing);
DCA_REGISTER_CONTROLLER(DistanceThreshold);
DCA_REGISTER_CONTROLLER(ForceThreshold);
DCA_REGISTER_CONTROLLER(LinearTrajectory);
DCA_REGISTER_CONTROLLER(PressHandle);
DCA_REGISTER_CONTROLLER(CompliantCtrl);
DCA_REGISTER_CONTROLLER(ModelBasedCtrl);
DCA_REGISTER_CONTROLLER(ConfigCtrl);

}  // namespace dca::door
