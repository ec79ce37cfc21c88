#include "worlds/door/world.h"

#include <Simbody.h>
#include <urdf_model/model.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <unistd.h>

#include "host/paths.h"
#include "sim/urdf_loader.h"

namespace dca::sim {
namespace {

constexpr int kRobotDofs = 11;  // base yaw, x, y; arm 1-6; finger left, right
constexpr int kArm0 = 3, kFingerL = 9, kFingerR = 10;
constexpr double kFingerOpen = 0.044, kFingerSpeed = 0.05;

Eigen::Isometry3d to_eigen(const SimTK::Transform& X) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T.linear()(r, c) = X.R()[r][c];
    T.translation()(r) = X.p()[r];
  }
  return T;
}

SimTK::Transform planar(const Pose2& p) {
  return SimTK::Transform(SimTK::Rotation(p.yaw, SimTK::ZAxis), SimTK::Vec3(p.x, p.y, 0));
}

// splitmix64: a tiny, fully specified generator, so a seed means the same world everywhere.
struct SplitMix {
  std::uint64_t s;
  std::uint64_t next() {
    std::uint64_t z = (s += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  double uniform(double lo, double hi) { return lo + (hi - lo) * static_cast<double>(next() >> 11) * 0x1.0p-53; }
};

struct Sphere {
  SimTK::MobilizedBodyIndex body;
  SimTK::Vec3 centre;  // in the body frame
  double radius;
};

}  // namespace

Pose2 nominal_base_start() { return {0.0, 0.0, 0.0}; }

std::array<double, 6> nominal_arm_start() { return {0.1513, 0.711, -3.428, 0.1658, 1.151, 1.503}; }

WorldConfig door_world(std::uint64_t seed, double door_width) {
  WorldConfig c;
  c.base_start = nominal_base_start();
  c.arm_start = nominal_arm_start();
  if (seed != 0) {
    SplitMix rng{seed};
    c.base_start.x += rng.uniform(-0.3, 0.3);
    c.base_start.y += rng.uniform(-0.3, 0.3);
    c.base_start.yaw += rng.uniform(-15.0, 15.0) * SimTK::Pi / 180;
    c.door.width = rng.uniform(0.8, 1.0);
  }
  if (door_width > 0) c.door.width = door_width;
  // The handle's pivot at y = 0, the approach face at x = 2.
  c.door_pose = {2.0, -(c.door.width - c.door.handle_backset), 0.0};
  return c;
}

struct World::Impl {
  WorldConfig config;
  SimTK::MultibodySystem system;
  SimTK::SimbodyMatterSubsystem matter{system};
  SimTK::GeneralForceSubsystem forces{system};
  SimTK::Vec3 g{0, 0, -9.81};
  SimTK::Force::UniformGravity gravity{forces, matter, g};
  LoadedUrdf robot, door;
  SimTK::State state;

  // Robot degrees of freedom, in the order of kRobotDofs.
  std::array<SimTK::MobilizedBodyIndex, kRobotDofs> dof_body{};
  std::array<int, kRobotDofs> dof_local{};
  std::array<SimTK::QIndex, kRobotDofs> dof_q{};
  std::array<SimTK::UIndex, kRobotDofs> dof_u{};
  std::array<double, kRobotDofs> effort{};
  mutable std::array<double, kRobotDofs> applied{};  // the drives' forces at the last force evaluation
  std::vector<SimTK::MobilizedBodyIndex> robot_bodies;
  SimTK::MobilizedBodyIndex hinge_body, handle_body, palm_body, ft_body;
  SimTK::QIndex hinge_q, handle_q;
  SimTK::UIndex hinge_u, handle_u;
  SimTK::Transform X_palm_tool;  // tool0 on the palm body
  // Sensor frames: body and the frame on it.
  SimTK::MobilizedBodyIndex laser_body, camera_body, grasp_body;
  SimTK::Transform X_laser, X_camera, X_grasp;

  // Servo state: references and rate commands (base rates in the base frame, converted in the force).
  std::array<double, kRobotDofs> q_ref{}, u_cmd{};
  Commands commands;
  double kp = 0, kv = 0;
  bool dirty = true;

  // Door: latch, disturbances.
  bool latched = true;
  double hinge_disturbance = 0, handle_disturbance = 0;
  // Gripper.
  double finger_target = kFingerOpen;
  bool grasp_candidate = false, grasped = false;
  SimTK::Constraint::Ball ball;
  std::vector<Sphere> spheres;

  Sensors sensors;
  std::unique_ptr<SimTK::Visualizer> visualizer;
  long steps = 0;
  // Buffers reused every step, so that a step allocates only inside Simbody (docs/time.md, "Where a door run's
  // time goes").
  mutable SimTK::Vector a_des, tau, zero_mobility;
  mutable SimTK::Vector_<SimTK::SpatialVec> gravity_forces;
  SimTK::Vector udot, qdot;
  SimTK::Vector_<SimTK::SpatialVec> reactions;

  explicit Impl(const WorldConfig& c);
  void build();
  void update_gripper();
  void update_latch();
  bool bar_between_fingers(double half_opening, SimTK::Vec3* point_G) const;
  void compute_sensors();
  void servo_forces(const SimTK::State& s, SimTK::Vector& mobility) const;
  void door_forces(const SimTK::State& s, SimTK::Vector& mobility) const;
  void contact_forces(const SimTK::State& s, SimTK::Vector_<SimTK::SpatialVec>& body) const;
};


namespace {

// The world's own forces (servos, door spring and latch, gripper contact) as one Simbody force element that
// reads the world's discrete state (commands, references, latch) from the Impl.
class WorldForces : public SimTK::Force::Custom::Implementation {
 public:
  explicit WorldForces(const World::Impl* w) : w_(w) {}
  void calcForce(const SimTK::State& s, SimTK::Vector_<SimTK::SpatialVec>& body, SimTK::Vector_<SimTK::Vec3>&,
                 SimTK::Vector& mobility) const override;
  SimTK::Real calcPotentialEnergy(const SimTK::State&) const override { return 0; }

 private:
  const World::Impl* w_;
};

}  // namespace

World::Impl::Impl(const WorldConfig& c) : config(c) {
  if (!(config.period > 0 && config.period <= 0.01)) throw std::invalid_argument("period must be in (0, 10 ms]");
  if (config.robot_urdf.empty()) config.robot_urdf = dca::models_dir() + "/mobile_manipulator.urdf";
  kp = config.servo_bandwidth * config.servo_bandwidth;
  kv = 2 * config.servo_bandwidth;
  build();
}

void World::Impl::build() {
  LoaderOptions options;
  options.period = config.period;
  const ParsedUrdf robot_urdf = parse_urdf_file(config.robot_urdf);
  robot = add_urdf(matter, forces, robot_urdf, matter.updGround(), SimTK::Transform(), options);
  const ParsedUrdf door_urdf_parsed = parse_urdf_string(door_urdf(config.door), "door.urdf(width=" +
                                                        std::to_string(config.door.width) + ")");
  door = add_urdf(matter, forces, door_urdf_parsed, matter.updGround(), planar(config.door_pose), options);

  const auto joint = [&](const LoadedUrdf& u, const std::string& name) {
    const LoadedJoint* j = u.joint(name);
    if (!j) throw UrdfError(u.file + ": the world needs a joint named '" + name + "'");
    return j->body;
  };
  const auto effort_of = [&](const std::string& name, double fallback) {
    const urdf::JointConstSharedPtr j = robot_urdf.model->getJoint(name);
    return j && j->limits && j->limits->effort > 0 ? j->limits->effort : fallback;
  };
  const SimTK::MobilizedBodyIndex base = joint(robot, "base_joint");
  for (int i = 0; i < 3; ++i) dof_body[i] = base, dof_local[i] = i;
  effort[0] = 300, effort[1] = 1500, effort[2] = 1500;  // the base's drives: N m, N, N
  for (int i = 0; i < 6; ++i) {
    const std::string name = "arm_joint_" + std::to_string(i + 1);
    dof_body[kArm0 + i] = joint(robot, name), dof_local[kArm0 + i] = 0;
    effort[kArm0 + i] = effort_of(name, 100);
  }
  dof_body[kFingerL] = joint(robot, "finger_left_joint"), dof_local[kFingerL] = 0;
  dof_body[kFingerR] = joint(robot, "finger_right_joint"), dof_local[kFingerR] = 0;
  effort[kFingerL] = effort_of("finger_left_joint", 100), effort[kFingerR] = effort_of("finger_right_joint", 100);
  for (const auto& [link, body] : robot.link_body)
    if (std::find(robot_bodies.begin(), robot_bodies.end(), body) == robot_bodies.end() &&
        body != SimTK::GroundIndex)
      robot_bodies.push_back(body);
  hinge_body = joint(door, "door_hinge");
  handle_body = joint(door, "door_handle_joint");
  palm_body = robot.link_body.at("gripper_palm");
  ft_body = robot.weld_body.at("ft_joint");
  X_palm_tool = robot.link_in_body.at("tool0");
  const auto frame = [&](const std::string& link, SimTK::MobilizedBodyIndex& body, SimTK::Transform& X) {
    if (!robot.link_body.count(link)) throw UrdfError(robot.file + ": the world needs a link named '" + link + "'");
    body = robot.link_body.at(link);
    X = robot.link_in_body.at(link);
  };
  frame("laser_link", laser_body, X_laser);
  frame("camera_link", camera_body, X_camera);
  grasp_body = door.link_body.at("door_grasp");
  X_grasp = door.link_in_body.at("door_grasp");

  // Contact spheres: the palm's face and the fingers (see mobile_manipulator.urdf).
  spheres = {{palm_body, {0, 0, 0.03}, 0.02},
             {palm_body, {0, 0.045, 0.03}, 0.02},
             {palm_body, {0, -0.045, 0.03}, 0.02},
             {dof_body[kFingerL], {0, 0.005, 0.054}, 0.006},
             {dof_body[kFingerL], {0, 0.005, 0.02}, 0.006},
             {dof_body[kFingerR], {0, -0.005, 0.054}, 0.006},
             {dof_body[kFingerR], {0, -0.005, 0.02}, 0.006}};

  ball = SimTK::Constraint::Ball(matter.updMobilizedBody(palm_body), SimTK::Vec3(0),
                                 matter.updMobilizedBody(handle_body), SimTK::Vec3(0));
  ball.setDisabledByDefault(true);
  SimTK::Force::Custom(forces, new WorldForces(this));

  state = system.realizeTopology();
  system.realizeModel(state);
  for (int i = 0; i < kRobotDofs; ++i) {
    const SimTK::MobilizedBody& m = matter.getMobilizedBody(dof_body[i]);
    dof_q[i] = SimTK::QIndex(m.getFirstQIndex(state) + dof_local[i]);
    dof_u[i] = SimTK::UIndex(m.getFirstUIndex(state) + dof_local[i]);
  }
  hinge_q = matter.getMobilizedBody(hinge_body).getFirstQIndex(state);
  hinge_u = matter.getMobilizedBody(hinge_body).getFirstUIndex(state);
  handle_q = matter.getMobilizedBody(handle_body).getFirstQIndex(state);
  handle_u = matter.getMobilizedBody(handle_body).getFirstUIndex(state);

  SimTK::Vector& q = state.updQ();
  q[dof_q[0]] = config.base_start.yaw, q[dof_q[1]] = config.base_start.x, q[dof_q[2]] = config.base_start.y;
  for (int i = 0; i < 6; ++i) q[dof_q[kArm0 + i]] = config.arm_start[static_cast<size_t>(i)];
  q[dof_q[kFingerL]] = q[dof_q[kFingerR]] = kFingerOpen;
  for (int i = 0; i < kRobotDofs; ++i) q_ref[i] = q[dof_q[i]];
  q[hinge_q] = config.door_start;
  q[handle_q] = config.handle_start;
  latched = config.door_start <= config.door.latch_play;
  a_des.resize(state.getNU());
  zero_mobility.resize(state.getNU());
  zero_mobility = 0;
  gravity_forces.resize(matter.getNumBodies());
  system.realize(state, SimTK::Stage::Acceleration);
  compute_sensors();
}

void World::Impl::servo_forces(const SimTK::State& s, SimTK::Vector& mobility) const {
  const SimTK::Vector& q = s.getQ();
  const SimTK::Vector& u = s.getU();
  // Commanded rates: the base's come in its own frame; its mobilizer's are in the world frame.
  std::array<double, kRobotDofs> rate = u_cmd;
  const double yaw = q[dof_q[0]], c = std::cos(yaw), sn = std::sin(yaw);
  rate[0] = commands.base_vel[2];
  rate[1] = c * commands.base_vel[0] - sn * commands.base_vel[1];
  rate[2] = sn * commands.base_vel[0] + c * commands.base_vel[1];
  a_des = 0;
  for (int i = 0; i < kRobotDofs; ++i)
    a_des[dof_u[i]] = kv * (rate[i] - u[dof_u[i]]) + kp * (q_ref[i] - q[dof_q[i]]);
  // Computed torque: M a_des plus what gravity and the velocity terms need, for the robot's joints.
  gravity_forces = SimTK::SpatialVec(SimTK::Vec3(0), SimTK::Vec3(0));
  for (const SimTK::MobilizedBodyIndex b : robot_bodies) {
    const SimTK::MobilizedBody& m = matter.getMobilizedBody(b);
    const double mass = m.getBodyMass(s);
    if (mass <= 0) continue;
    const SimTK::Vec3 com_G = m.getBodyRotation(s) * m.getBodyMassCenterStation(s);
    gravity_forces[b] = SimTK::SpatialVec(com_G % (mass * g), mass * g);
  }
  matter.calcResidualForceIgnoringConstraints(s, zero_mobility, gravity_forces, a_des, tau);
  for (int i = 0; i < kRobotDofs; ++i) {
    applied[i] = std::clamp(static_cast<double>(tau[dof_u[i]]), -effort[i], effort[i]);
    mobility[dof_u[i]] += applied[i];
  }
}

void World::Impl::door_forces(const SimTK::State& s, SimTK::Vector& mobility) const {
  const DoorParams& d = config.door;
  const double qh = s.getQ()[handle_q];
  mobility[handle_u] += handle_disturbance - d.handle_preload - d.handle_spring * qh;
  mobility[hinge_u] += hinge_disturbance;
  if (latched) {
    const double qd = s.getQ()[hinge_q], ud = s.getU()[hinge_u];
    if (qd > d.latch_play)
      mobility[hinge_u] += std::min(0.0, -d.latch_stiffness * (qd - d.latch_play) - d.latch_damping * ud);
  }
}

namespace {

constexpr double kContactStiffness = 1e4, kContactDamping = 30;

// Closest point to p on segment ab.
SimTK::Vec3 closest_on_segment(const SimTK::Vec3& p, const SimTK::Vec3& a, const SimTK::Vec3& b) {
  const SimTK::Vec3 ab = b - a;
  const double t = std::clamp(SimTK::dot(p - a, ab) / SimTK::dot(ab, ab), 0.0, 1.0);
  return a + t * ab;
}

}  // namespace

void World::Impl::contact_forces(const SimTK::State& s, SimTK::Vector_<SimTK::SpatialVec>& body) const {
  const DoorParams& d = config.door;
  const SimTK::MobilizedBody& handle = matter.getMobilizedBody(handle_body);
  const SimTK::MobilizedBody& leaf = matter.getMobilizedBody(hinge_body);
  const SimTK::Transform& X_GH = handle.getBodyTransform(s);
  const SimTK::Transform& X_GL = leaf.getBodyTransform(s);
  // The handle as two capsules: the spindle from the leaf to the bar, and the bar.
  const SimTK::Vec3 spindle_a = X_GH * SimTK::Vec3(0, 0, 0), bar_a = X_GH * SimTK::Vec3(-d.handle_standoff, 0, 0);
  const SimTK::Vec3 bar_b = X_GH * SimTK::Vec3(-d.handle_standoff, -d.lever_length, 0);
  const auto push = [&](const SimTK::MobilizedBody& a, const SimTK::MobilizedBody& b, const SimTK::Vec3& p_G,
                        const SimTK::Vec3& n_G, double depth) {
    // n_G points from b into a; the force pushes a along n and b against it.
    const SimTK::Vec3 v_rel = a.findStationVelocityInGround(s, a.findStationAtGroundPoint(s, p_G)) -
                              b.findStationVelocityInGround(s, b.findStationAtGroundPoint(s, p_G));
    const double f = std::max(0.0, kContactStiffness * depth - kContactDamping * SimTK::dot(v_rel, n_G));
    a.applyForceToBodyPoint(s, a.findStationAtGroundPoint(s, p_G), f * n_G, body);
    b.applyForceToBodyPoint(s, b.findStationAtGroundPoint(s, p_G), -f * n_G, body);
  };
  for (const Sphere& sp : spheres) {
    const SimTK::MobilizedBody& m = matter.getMobilizedBody(sp.body);
    const SimTK::Vec3 c = m.getBodyTransform(s) * sp.centre;
    if (!grasped) {
      const SimTK::Vec3 ends[2][2] = {{spindle_a, bar_a}, {bar_a, bar_b}};
      const double radii[2] = {0.008, d.lever_radius};
      for (int k = 0; k < 2; ++k) {
        const SimTK::Vec3 p = closest_on_segment(c, ends[k][0], ends[k][1]);
        const SimTK::Vec3 r = c - p;
        const double dist = r.norm(), depth = sp.radius + radii[k] - dist;
        if (depth > 0 && dist > 1e-9) push(m, handle, p + r * (radii[k] / dist), r / dist, depth);
      }
    }
    // The leaf's approach face (x = 0 in the leaf frame), within the leaf's outline.
    const SimTK::Vec3 c_L = ~X_GL * c;
    const double depth = sp.radius + c_L[0];
    if (depth > 0 && c_L[0] < d.thickness / 2 && c_L[1] > 0 && c_L[1] < d.width && c_L[2] > 0 &&
        c_L[2] < d.height) {
      const SimTK::Vec3 n_G = X_GL.R() * SimTK::Vec3(-1, 0, 0);
      push(m, leaf, X_GL * SimTK::Vec3(0, c_L[1], c_L[2]), n_G, depth);
    }
  }
}

void WorldForces::calcForce(const SimTK::State& s, SimTK::Vector_<SimTK::SpatialVec>& body,
                            SimTK::Vector_<SimTK::Vec3>&, SimTK::Vector& mobility) const {
  w_->servo_forces(s, mobility);
  w_->door_forces(s, mobility);
  w_->contact_forces(s, body);
}

bool World::Impl::bar_between_fingers(double half_opening, SimTK::Vec3* point_G) const {
  const DoorParams& d = config.door;
  const SimTK::Transform& X_GH = matter.getMobilizedBody(handle_body).getBodyTransform(state);
  const SimTK::Transform X_GT = matter.getMobilizedBody(palm_body).getBodyTransform(state) * X_palm_tool;
  const SimTK::Vec3 a = X_GH * SimTK::Vec3(-d.handle_standoff, 0, 0);
  const SimTK::Vec3 b = X_GH * SimTK::Vec3(-d.handle_standoff, -d.lever_length, 0);
  const SimTK::Vec3 p = closest_on_segment(X_GT.p(), a, b);
  const SimTK::Vec3 p_T = ~X_GT * p;
  const SimTK::Vec3 bar_T = ~X_GT.R() * (b - a).normalize();
  // In the slot between the fingers: across it (not along the opening axis), between palm and fingertips.
  const bool inside = std::abs(bar_T[1]) < 0.5 && std::abs(p_T[0]) < 0.03 && std::abs(p_T[1]) < half_opening &&
                      p_T[2] > -0.015 && p_T[2] < 0.05;
  if (inside && point_G) *point_G = p;
  return inside;
}

void World::Impl::update_gripper() {
  const bool close = commands.gripper_close;
  const double target_before = finger_target;
  if (close && finger_target == kFingerOpen) {  // the close command's edge
    grasp_candidate = bar_between_fingers(kFingerOpen, nullptr);
    finger_target = grasp_candidate ? config.door.lever_radius : 0.0;
  } else if (!close && finger_target != kFingerOpen) {
    finger_target = kFingerOpen;
    grasp_candidate = false;
    if (grasped) {
      ball.disable(state);
      grasped = false;
    }
  }
  if (finger_target != target_before) dirty = true;
  const double h = config.period;
  for (const int i : {kFingerL, kFingerR}) {
    const double step = std::clamp(finger_target - q_ref[i], -kFingerSpeed * h, kFingerSpeed * h);
    const double rate = step / h;
    if (rate != u_cmd[i]) dirty = true;
    u_cmd[i] = rate;
  }
  const SimTK::Vector& q = state.getQ();
  const bool reached = std::abs(q[dof_q[kFingerL]] - finger_target) < 2e-3 &&
                       std::abs(q[dof_q[kFingerR]] - finger_target) < 2e-3 && u_cmd[kFingerL] == 0;
  if (close && grasp_candidate && !grasped && reached) {
    SimTK::Vec3 p;
    if (bar_between_fingers(0.045, &p)) {
      const SimTK::MobilizedBody& palm = matter.getMobilizedBody(palm_body);
      const SimTK::MobilizedBody& handle = matter.getMobilizedBody(handle_body);
      const SimTK::Vec3 on_palm = palm.findStationAtGroundPoint(state, p);
      const SimTK::Vec3 on_handle = handle.findStationAtGroundPoint(state, p);
      ball.setPointOnBody1(state, on_palm);
      ball.setPointOnBody2(state, on_handle);
      ball.enable(state);
      grasped = true;
      system.realize(state, SimTK::Stage::Velocity);
      system.projectU(state, 1e-8);
    } else {
      grasp_candidate = false;
    }
  }
}

void World::Impl::update_latch() {
  const DoorParams& d = config.door;
  const bool before = latched;
  const SimTK::Vector& q = state.getQ();
  if (q[handle_q] >= d.latch_release && !d.latch_jammed) latched = false;
  else if (q[hinge_q] <= d.latch_play) latched = true;
  if (latched != before) dirty = true;
}

void World::Impl::compute_sensors() {
  const SimTK::State& s = state;
  Sensors& o = sensors;
  const SimTK::Vector& q = s.getQ();
  const SimTK::Vector& u = s.getU();
  o.time = s.getTime();
  for (int i = 0; i < 6; ++i) {
    o.arm_q[static_cast<size_t>(i)] = q[dof_q[kArm0 + i]];
    o.arm_qd[static_cast<size_t>(i)] = u[dof_u[kArm0 + i]];
    o.arm_effort[static_cast<size_t>(i)] = applied[kArm0 + i];
  }
  const double yaw = q[dof_q[0]], c = std::cos(yaw), sn = std::sin(yaw);
  o.base_pose = {q[dof_q[1]], q[dof_q[2]], yaw};
  const double xd = u[dof_u[1]], yd = u[dof_u[2]];
  o.base_vel = {c * xd + sn * yd, -sn * xd + c * yd, u[dof_u[0]]};
  // Wrench: the weld's reaction is what the arm applies to the tool; the tool applies its opposite.
  matter.calcMobilizerReactionForces(s, reactions);
  const SimTK::Rotation& R_GS = matter.getMobilizedBody(ft_body).getBodyRotation(s);
  const SimTK::Vec3 torque = ~R_GS * -reactions[ft_body][0], force = ~R_GS * -reactions[ft_body][1];
  for (int i = 0; i < 3; ++i) {
    o.wrench[static_cast<size_t>(i)] = force[i];
    o.wrench[static_cast<size_t>(3 + i)] = torque[i];
  }
  // Laser: along laser_link's x to the door's plane (the closed leaf's approach face, x = 0 of door_frame).
  const SimTK::Transform X_laser_G = matter.getMobilizedBody(laser_body).getBodyTransform(s) * X_laser;
  const SimTK::Transform X_door = planar(config.door_pose);
  const SimTK::Vec3 n = X_door.R() * SimTK::Vec3(1, 0, 0), dir = X_laser_G.R() * SimTK::Vec3(1, 0, 0);
  const double nd = SimTK::dot(n, dir);
  o.laser_range = config.laser_max_range;
  if (nd > 1e-9) {
    const double t = SimTK::dot(n, X_door.p() - X_laser_G.p()) / nd;
    if (t >= 0 && t < config.laser_max_range) o.laser_range = t;
  }
  // Camera: pinhole along camera_link's x (y left, z up) -> pixels (u right, v down).
  const SimTK::Transform X_cam = matter.getMobilizedBody(camera_body).getBodyTransform(s) * X_camera;
  const SimTK::Vec3 p_c = ~X_cam * (matter.getMobilizedBody(grasp_body).getBodyTransform(s) * X_grasp.p());
  const CameraParams& cam = config.camera;
  const double f = 0.5 * cam.width / std::tan(0.5 * cam.hfov);
  o.camera_handle = {-1, -1, 0};
  if (p_c[0] > 0.05) {
    const double px = 0.5 * cam.width - f * p_c[1] / p_c[0], py = 0.5 * cam.height - f * p_c[2] / p_c[0];
    if (px >= 0 && px < cam.width && py >= 0 && py < cam.height) o.camera_handle = {px, py, 1};
  }
  o.door_angle = q[hinge_q];
  o.handle_angle = q[handle_q];
  o.gripper_width = q[dof_q[kFingerL]] + q[dof_q[kFingerR]];
  const bool reached = std::abs(q[dof_q[kFingerL]] - finger_target) < 2e-3 &&
                       std::abs(q[dof_q[kFingerR]] - finger_target) < 2e-3 && u_cmd[kFingerL] == 0;
  if (grasped) o.gripper = GripperState::grasping;
  else if (!reached) o.gripper = GripperState::moving;
  else if (finger_target == kFingerOpen) o.gripper = GripperState::open;
  else o.gripper = grasped ? GripperState::grasping : GripperState::closed;
}

World::World(const WorldConfig& config) : impl_(std::make_unique<Impl>(config)) {}
World::~World() = default;

void World::set_commands(const Commands& c) {
  Impl& w = *impl_;
  if (c.base_vel != w.commands.base_vel || c.arm_qd != w.commands.arm_qd) w.dirty = true;
  w.commands = c;
  for (int i = 0; i < 6; ++i) w.u_cmd[kArm0 + i] = c.arm_qd[static_cast<size_t>(i)];
}

void World::step() {
  Impl& w = *impl_;
  SimTK::State& s = w.state;
  const double h = w.config.period;
  w.update_gripper();
  w.update_latch();
  if (w.dirty) s.invalidateAllCacheAtOrAbove(SimTK::Stage::Dynamics);
  w.system.realize(s, SimTK::Stage::Acceleration);
  // Semi-explicit Euler: u1 = u0 + h udot(t0), q1 = q0 + h N(q0) u1, then back onto the constraints.
  w.udot = s.getUDot();
  w.udot *= h;
  s.updU() += w.udot;
  w.matter.multiplyByN(s, false, s.getU(), w.qdot);
  w.qdot *= h;
  s.updQ() += w.qdot;
  s.updTime() += h;
  w.system.realize(s, SimTK::Stage::Position);
  if (w.grasped) w.system.projectQ(s, 1e-8);
  w.system.realize(s, SimTK::Stage::Velocity);
  if (w.grasped) w.system.projectU(s, 1e-8);
  // The servo references follow the commanded rates, within the following-error bound.
  const SimTK::Vector& q = s.getQ();
  const double yaw = q[w.dof_q[0]], c = std::cos(yaw), sn = std::sin(yaw);
  std::array<double, kRobotDofs> rate = w.u_cmd;
  rate[0] = w.commands.base_vel[2];
  rate[1] = c * w.commands.base_vel[0] - sn * w.commands.base_vel[1];
  rate[2] = sn * w.commands.base_vel[0] + c * w.commands.base_vel[1];
  for (int i = 0; i < kRobotDofs; ++i) {
    const double qi = q[w.dof_q[i]], e = w.config.following_error;
    w.q_ref[i] = std::clamp(w.q_ref[i] + h * rate[i], qi - e, qi + e);
  }
  s.invalidateAllCacheAtOrAbove(SimTK::Stage::Dynamics);
  w.system.realize(s, SimTK::Stage::Acceleration);
  w.dirty = false;
  w.compute_sensors();
  if (w.visualizer && ++w.steps % std::max(1L, std::lround(1.0 / (30 * h))) == 0) w.visualizer->report(s);
}

bool World::start_visualizer(std::string* error) {
  const char* display = std::getenv("DISPLAY");
  if (!display || !*display) return *error = "no display (DISPLAY is not set)", false;
  namespace fs = std::filesystem;
  // Debian's libsimbody ships the visualizer as simbody-visualizer; Simbody looks for simbody-visualizer_d.
  const fs::path shipped = "/usr/lib/x86_64-linux-gnu/simbody/libexec/simbody-visualizer";
  std::error_code ec;
  if (fs::exists(shipped, ec) && !std::getenv("SIMBODY_HOME")) {
    const fs::path home = fs::temp_directory_path(ec) / ("dca-simbody-home-" + std::to_string(getpid()));
    const fs::path link = home / "libexec" / "simbody" / "simbody-visualizer_d";
    fs::create_directories(link.parent_path(), ec);
    if (!fs::exists(link, ec)) fs::create_symlink(shipped, link, ec);
    setenv("SIMBODY_HOME", home.c_str(), 1);
  }
  try {
    impl_->visualizer = std::make_unique<SimTK::Visualizer>(impl_->system);
    impl_->visualizer->setShowSimTime(true);
    impl_->visualizer->report(impl_->state);
  } catch (const std::exception& e) {
    impl_->visualizer.reset();
    *error = std::string("the visualizer did not start: ") + e.what();
    return false;
  }
  return true;
}

const Sensors& World::sensors() const { return impl_->sensors; }
double World::time() const { return impl_->state.getTime(); }
const WorldConfig& World::config() const { return impl_->config; }

Eigen::Isometry3d World::link_pose(const std::string& link) const {
  const Impl& w = *impl_;
  if (w.robot.link_body.count(link)) return to_eigen(w.robot.link_pose(w.matter, w.state, link));
  return to_eigen(w.door.link_pose(w.matter, w.state, link));
}

Eigen::Matrix<double, 6, 6> World::tool_jacobian() const {
  const Impl& w = *impl_;
  SimTK::RowVector_<SimTK::SpatialVec> J;
  w.matter.calcFrameJacobian(w.state, w.palm_body, w.X_palm_tool.p(), J);
  Eigen::Matrix<double, 6, 6> out;
  for (int j = 0; j < 6; ++j) {
    const SimTK::SpatialVec& col = J[w.dof_u[kArm0 + j]];
    for (int r = 0; r < 3; ++r) {
      out(r, j) = col[0][r];
      out(3 + r, j) = col[1][r];
    }
  }
  return out;
}

bool World::grasping() const { return impl_->grasped; }
bool World::latched() const { return impl_->latched; }

void World::set_disturbance(double hinge_torque, double handle_torque) {
  impl_->hinge_disturbance = hinge_torque;
  impl_->handle_disturbance = handle_torque;
  impl_->dirty = true;
}

}  // namespace dca::sim
