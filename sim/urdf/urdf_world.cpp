// The Simbody world of a URDF robot (docs/robots.md): the robot's tree from sim/urdf_loader.h, its root welded to
// the ground, gravity, and one servo per commanded joint as a mobility force, stepped with semi-explicit Euler
// (sim/urdf/integrate.h, the same step as the baseline of tests/bench/urdf_world_bench.cpp).
#include <Simbody.h>

#include <algorithm>
#include <cmath>
#include <set>

#include <urdf_model/model.h>

#include "sim/urdf/integrate.h"
#include "sim/urdf/joint_world.h"
#include "sim/urdf_loader.h"

namespace dca::sim {
namespace {

constexpr double kBandwidth = 50;  // rad/s: the default servos' natural frequency

// One joint as Simbody sees it, with its servo's gains and state.
struct Servo {
  SimTK::QIndex q;
  SimTK::UIndex u;
  double inertia = 1;           // M_jj at the start: the default gains' scale
  double integral = 0;          // position: of q_cmd - q; velocity: of qd_cmd - qd
  double effort_limit = 0;
  JointInterface kind = JointInterface::effort;
  std::size_t input = SIZE_MAX; // the command input the integral belongs to
  std::uint64_t saturated = 0;  // steps at the effort limit
};

// A servo's gains: the declared ones, else scaled by the joint's inertia for the default bandwidth
// (docs/robots.md). Position: p on the error, i on its integral, d on the velocity; velocity: p on the velocity
// error, i on its integral.
struct Gains {
  double p = 0, i = 0, d = 0;
};
Gains gains(const Servo& sv, const CommandSpec& c) {
  const double I = sv.inertia, w = kBandwidth;
  const auto pick = [](double declared, double fallback) { return std::isnan(declared) ? fallback : declared; };
  Gains g;
  if (c.kind == JointInterface::position) {
    g.p = pick(c.p, I * w * w);
    g.i = pick(c.i, g.p * w / 10);
    g.d = pick(c.d, 2 * I * w);
  } else if (c.kind == JointInterface::velocity) {
    g.p = pick(c.p, 2 * I * w);
    g.i = pick(c.i, I * w * w);
  }
  return g;
}

class SimbodyWorld;

// The servos as one force element: mobility forces from the drives of the step.
class ServoForces : public SimTK::Force::Custom::Implementation {
 public:
  explicit ServoForces(SimbodyWorld* w) : w_(w) {}
  void calcForce(const SimTK::State& s, SimTK::Vector_<SimTK::SpatialVec>&, SimTK::Vector_<SimTK::Vec3>&,
                 SimTK::Vector& mobility) const override;
  SimTK::Real calcPotentialEnergy(const SimTK::State&) const override { return 0; }

 private:
  SimbodyWorld* w_;
};

class SimbodyWorld final : public JointWorld {
 public:
  SimbodyWorld(RobotDescription d, double period) : JointWorld(std::move(d), period) {
    SimTK::Force::UniformGravity(forces_, matter_, SimTK::Vec3(0, 0, -9.81));
    LoaderOptions options;
    options.period = period;
    loaded_ = add_urdf(matter_, forces_, description_.urdf, matter_.updGround(), SimTK::Transform(), options);
    SimTK::Force::Custom(forces_, new ServoForces(this));
    state_sim_ = system_.realizeTopology();
    system_.realizeModel(state_sim_);
    servos_.resize(description_.joints.size());
    for (std::size_t j = 0; j < servos_.size(); ++j) {
      const LoadedJoint* lj = loaded_.joint(description_.joints[j].name);
      if (!lj) throw UrdfError(description_.joints[j].where + ": joint '" + description_.joints[j].name + "' is not in the Simbody tree");
      const SimTK::MobilizedBody& m = matter_.getMobilizedBody(lj->body);
      servos_[j].q = m.getFirstQIndex(state_sim_);
      servos_[j].u = m.getFirstUIndex(state_sim_);
      servos_[j].effort_limit = description_.joints[j].limits.effort;
      state_sim_.updQ()[servos_[j].q] = description_.joints[j].initial;
    }
    system_.realize(state_sim_, SimTK::Stage::Position);
    SimTK::Matrix M;
    matter_.calcM(state_sim_, M);
    for (auto& s : servos_) s.inertia = std::max(1e-6, static_cast<double>(M(s.u, s.u)));
    efforts_.assign(servos_.size(), 0.0);
    for (const auto& sensor : description_.sensors) ft_bodies_.push_back(subtree_bodies(sensor));
    system_.realize(state_sim_, SimTK::Stage::Velocity);
  }

  // The effort of joint `j` under its drive at state `s` (clamped at the effort limit; `raw` before the clamp).
  double effort(std::size_t j, const SimTK::State& s, double* raw) const {
    const JointDrive& d = interfaces_.drive(j);
    const Servo& sv = servos_[j];
    if (!d.commanded) return *raw = 0;
    const double q = s.getQ()[sv.q], u = s.getU()[sv.u];
    const Gains g = gains(sv, interfaces_.spec_of(d.input));
    const double integral = sv.input == d.input ? sv.integral : 0.0;
    switch (d.kind) {
      case JointInterface::position:
        *raw = g.p * (d.value - q) + g.i * integral - g.d * u;
        break;
      case JointInterface::velocity:
        *raw = g.p * (d.value - u) + g.i * integral;
        break;
      case JointInterface::effort:
        *raw = d.value;
        break;
    }
    return std::clamp(*raw, -sv.effort_limit, sv.effort_limit);
  }
  SimTK::UIndex servo_u(std::size_t j) const { return servos_[j].u; }

  std::vector<double> efforts_;  // of the last force evaluation: the step's

 private:
  void advance() override {
    efforts_.assign(servos_.size(), 0.0);
    state_sim_.invalidateAllCacheAtOrAbove(SimTK::Stage::Dynamics);  // the drives changed
    euler_step(system_, matter_, state_sim_, period(), qdot_);
    const SimTK::Vector& q = state_sim_.getQ();
    const SimTK::Vector& u = state_sim_.getU();
    for (std::size_t j = 0; j < servos_.size(); ++j) {
      Servo& sv = servos_[j];
      state_[j] = {q[sv.q], u[sv.u], efforts_[j]};
      integrate_servo(j);
    }
  }

  // The servo's integral after the step (reset when the interface in force changes; held at the effort limit).
  void integrate_servo(std::size_t j) {
    Servo& sv = servos_[j];
    const JointDrive& d = interfaces_.drive(j);
    if (!d.commanded || d.kind == JointInterface::effort) return void(sv.input = SIZE_MAX);
    if (sv.input != d.input) sv.input = d.input, sv.integral = 0;
    const CommandSpec& c = interfaces_.spec_of(d.input);
    const double err = d.kind == JointInterface::position ? d.value - state_[j].position : d.value - state_[j].velocity;
    if (std::abs(state_[j].effort) >= sv.effort_limit) {
      ++sv.saturated;
      return;
    }
    sv.integral += period() * err;
    const double gain = gains(sv, c).i;
    if (gain > 0 && std::isfinite(sv.effort_limit))
      sv.integral = std::clamp(sv.integral, -sv.effort_limit / gain, sv.effort_limit / gain);
  }

  std::string kind() const override { return "Simbody world"; }

  // A force-torque sensor's bodies: those that carry the links below its joint (a massless link welded to its
  // parent's body adds nothing). Empty for other sensors.
  std::vector<SimTK::MobilizedBodyIndex> subtree_bodies(const SensorSpec& sensor) const {
    if (sensor.kind != SensorKind::force_torque) return {};
    std::set<std::string> below;
    std::vector<urdf::LinkConstSharedPtr> todo{description_.urdf.model->getLink(sensor.link)};
    while (!todo.empty()) {
      const urdf::LinkConstSharedPtr l = todo.back();
      todo.pop_back();
      if (!l) continue;
      below.insert(l->name);
      for (const auto& c : l->child_links) todo.push_back(c);
    }
    std::set<int> in, out;
    for (const auto& [link, body] : loaded_.link_body) (below.count(link) ? in : out).insert(int(body));
    std::vector<SimTK::MobilizedBodyIndex> bodies;
    for (const int b : in)
      if (!out.count(b)) bodies.emplace_back(b);
    return bodies;
  }

  // The wrench across a force-torque sensor's joint, from the motion of the bodies below it (Newton-Euler: what
  // the parent applies is their rate of change of momentum less their weight), about the point `o` in Ground.
  void subtree_wrench(const std::vector<SimTK::MobilizedBodyIndex>& bodies, const SimTK::Vec3& o, SimTK::Vec3* f,
                      SimTK::Vec3* t) const {
    const SimTK::Vec3 g(0, 0, -kGravity);
    for (const auto b : bodies) {
      const SimTK::MobilizedBody& mb = matter_.getMobilizedBody(b);
      const SimTK::MassProperties& mp = mb.getBodyMassProperties(state_sim_);
      const double m = mp.getMass();
      const SimTK::Rotation& R = mb.getBodyRotation(state_sim_);
      const SimTK::Vec3 c = mb.findStationLocationInGround(state_sim_, mp.getMassCenter());
      const SimTK::Vec3 a = mb.findStationAccelerationInGround(state_sim_, mp.getMassCenter());
      const SimTK::Vec3& w = mb.getBodyAngularVelocity(state_sim_);
      const SimTK::Vec3& alpha = mb.getBodyAngularAcceleration(state_sim_);
      const SimTK::Mat33 I = R * mp.calcCentralInertia().toMat33() * ~R;
      const SimTK::Vec3 force = m * (a - g);
      *f += force;
      *t += I * alpha + w % (I * w) + (c - o) % force;
    }
  }

  // Readings as docs/robots.md says ("Sensors"), from the state realized to Acceleration.
  void read_sensors(std::vector<double>& out) const override {
    out.clear();
    if (description_.sensors.empty()) return;
    system_.realize(state_sim_, SimTK::Stage::Acceleration);
    const auto put = [&out](const SimTK::Vec3& v) { out.insert(out.end(), {v[0], v[1], v[2]}); };
    for (std::size_t k = 0; k < description_.sensors.size(); ++k) {
      const SensorSpec& sensor = description_.sensors[k];
      const SimTK::Transform X_GL = loaded_.link_pose(matter_, state_sim_, sensor.link);
      const SimTK::MobilizedBody& mb = matter_.getMobilizedBody(loaded_.link_body.at(sensor.link));
      const SimTK::Vec3 station = loaded_.link_in_body.at(sensor.link).p();
      const SimTK::Vec3& w = mb.getBodyAngularVelocity(state_sim_);
      if (sensor.kind == SensorKind::force_torque) {
        SimTK::Vec3 f(0), t(0);
        subtree_wrench(ft_bodies_[k], X_GL.p(), &f, &t);
        const double sign = sensor.child_to_parent ? -1.0 : 1.0;  // f, t: what the parent applies on the child
        put(sign * (~X_GL.R() * f));
        put(sign * (~X_GL.R() * t));
      } else if (sensor.kind == SensorKind::imu) {
        const SimTK::Quaternion q = X_GL.R().convertRotationToQuaternion();  // (w, x, y, z)
        out.insert(out.end(), {q[1], q[2], q[3], q[0]});
        put(~X_GL.R() * w);
        put(~X_GL.R() * (mb.findStationAccelerationInGround(state_sim_, station) + SimTK::Vec3(0, 0, kGravity)));
      } else {
        const SimTK::Mat33 R = X_GL.R().asMat33();
        const double yaw = std::atan2(R(1, 0), R(0, 0));
        const SimTK::Vec3 v = SimTK::Rotation(-yaw, SimTK::ZAxis) * mb.findStationVelocityInGround(state_sim_, station);
        out.insert(out.end(), {X_GL.p()[0], X_GL.p()[1], yaw, v[0], v[1], w[2]});
      }
    }
  }
  // The frames from the bodies' transforms in Ground: each link's relative to its parent link's.
  void link_frames(double* out) const override {
    system_.realize(state_sim_, SimTK::Stage::Position);
    for (const auto& f : frames()) {
      const SimTK::Transform X_GC = loaded_.link_pose(matter_, state_sim_, f.child);
      const SimTK::Transform X_PC = f.parent == "world" ? X_GC : ~loaded_.link_pose(matter_, state_sim_, f.parent) * X_GC;
      const SimTK::Vec3& p = X_PC.p();
      const SimTK::Quaternion q = X_PC.R().convertRotationToQuaternion();  // (w, x, y, z)
      const double v[7] = {p[0], p[1], p[2], q[1], q[2], q[3], q[0]};
      for (const double x : v) *out++ = x;
    }
  }
  void more_status(StatusSink& sink) const override {
    std::vector<std::pair<std::string, double>> sat;
    for (std::size_t j = 0; j < servos_.size(); ++j)
      sat.emplace_back(description_.joints[j].name, static_cast<double>(servos_[j].saturated));
    sink.table("effort_saturated", sat);
  }
  void more_summary(std::vector<std::string>& lines) const override {
    for (std::size_t j = 0; j < servos_.size(); ++j)
      if (servos_[j].saturated > 0)
        lines.push_back("joint " + description_.joints[j].name + ": at its effort limit for " +
                        std::to_string(servos_[j].saturated) + " steps");
  }

  SimTK::MultibodySystem system_;
  SimTK::SimbodyMatterSubsystem matter_{system_};
  SimTK::GeneralForceSubsystem forces_{system_};
  LoadedUrdf loaded_;
  SimTK::State state_sim_;
  std::vector<Servo> servos_;
  std::vector<std::vector<SimTK::MobilizedBodyIndex>> ft_bodies_;  // per sensor (force-torque: its bodies)
  SimTK::Vector qdot_;
};

void ServoForces::calcForce(const SimTK::State& s, SimTK::Vector_<SimTK::SpatialVec>&, SimTK::Vector_<SimTK::Vec3>&,
                            SimTK::Vector& mobility) const {
  for (std::size_t j = 0; j < w_->efforts_.size(); ++j) {
    double raw = 0;
    const double e = w_->effort(j, s, &raw);
    w_->efforts_[j] = e;
    mobility[w_->servo_u(j)] += e;
  }
}

}  // namespace

std::unique_ptr<JointWorld> make_simbody_world(RobotDescription description, double period) {
  try {
    return std::make_unique<SimbodyWorld>(std::move(description), period);
  } catch (const UrdfError&) {
    throw;
  } catch (const std::exception& e) {
    throw UrdfError(std::string("Simbody rejects the model: ") + e.what());
  }
}

}  // namespace dca::sim
