#include "sim/urdf/sensors.h"

#include <urdf_model/model.h>

#include <Eigen/Geometry>
#include <cmath>
#include <map>

namespace dca::sim {
namespace {

// A link's motion in the world: its pose, its angular velocity and the velocity of its origin.
struct Motion {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  Eigen::Vector3d w = Eigen::Vector3d::Zero(), v = Eigen::Vector3d::Zero();
};

Eigen::Isometry3d pose_of(const urdf::Pose& o) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(o.rotation.w, o.rotation.x, o.rotation.y, o.rotation.z).normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(o.position.x, o.position.y, o.position.z);
  return T;
}

// The motion of every link below `link` (whose motion is in `m`), by the joints' positions and velocities.
void propagate(const RobotDescription& d, const urdf::Link& link, const std::vector<JointState>& state,
               std::map<std::string, Motion>& m) {
  for (std::size_t i = 0; i < link.child_joints.size() && i < link.child_links.size(); ++i) {
    const urdf::Joint& j = *link.child_joints[i];
    const Motion& p = m[link.name];
    Motion c;
    c.T = p.T * pose_of(j.parent_to_joint_origin_transform);
    Eigen::Vector3d axis(j.axis.x, j.axis.y, j.axis.z);
    axis = axis.norm() > 0 ? axis.normalized() : Eigen::Vector3d::UnitX();
    const JointSpec* spec = d.joint(j.name);
    const JointState s = spec ? state[static_cast<std::size_t>(spec - d.joints.data())] : JointState{};
    const Eigen::Vector3d axis_w = c.T.linear() * axis;
    c.w = p.w;
    c.v = p.v + p.w.cross(c.T.translation() - p.T.translation());
    if (spec && spec->linear) {
      c.T.translation() += axis_w * s.position;
      c.v += axis_w * s.velocity;
    } else if (spec) {
      c.T.linear() = c.T.linear() * Eigen::AngleAxisd(s.position, axis).toRotationMatrix();
      c.w += axis_w * s.velocity;
    }
    m[j.child_link_name] = c;
    if (link.child_links[i]) propagate(d, *link.child_links[i], state, m);
  }
}

// The weight of `link` and the links below it, with its moment about `o` (world axes): force, torque.
void subtree_weight(const urdf::Link& link, const std::map<std::string, Motion>& m, const Eigen::Vector3d& o,
                    Eigen::Vector3d& f, Eigen::Vector3d& t) {
  if (link.inertial) {
    const Eigen::Vector3d g = Eigen::Vector3d(0, 0, -kGravity) * link.inertial->mass;
    const Eigen::Vector3d c = m.at(link.name).T * pose_of(link.inertial->origin).translation();
    f += g;
    t += (c - o).cross(g);
  }
  for (const auto& child : link.child_links)
    if (child) subtree_weight(*child, m, o, f, t);
}

void put(const Eigen::Vector3d& v, double*& out) {
  for (int k = 0; k < 3; ++k) *out++ = v[k];
}

}  // namespace

const std::vector<SensorGroup>& sensor_groups(SensorKind kind) {
  static const std::vector<SensorGroup> ft = {{"force", {"x", "y", "z"}, "N, in link LINK"},
                                              {"torque", {"x", "y", "z"}, "N m about the origin of link LINK"}};
  static const std::vector<SensorGroup> imu = {
      {"orientation", {"x", "y", "z", "w"}, "unit quaternion: link LINK in the world"},
      {"angular_velocity", {"x", "y", "z"}, "rad/s, in link LINK"},
      {"linear_acceleration", {"x", "y", "z"}, "m/s², gravity's reaction included, in link LINK"}};
  static const std::vector<SensorGroup> odom = {{"pose", {"x", "y", "yaw"}, "m, m, rad: link LINK in the world"},
                                                {"twist", {"x", "y", "yaw"}, "m/s, m/s, rad/s: link LINK, in its heading"}};
  return kind == SensorKind::force_torque ? ft : kind == SensorKind::imu ? imu : odom;
}

bool sensor_kind_of(const std::string& group, SensorKind* kind) {
  for (const auto k : {SensorKind::force_torque, SensorKind::imu, SensorKind::odometry})
    for (const auto& g : sensor_groups(k))
      if (group == g.name) return *kind = k, true;
  return false;
}

std::size_t sensor_values(SensorKind kind) {
  std::size_t n = 0;
  for (const auto& g : sensor_groups(kind)) n += g.components.size();
  return n;
}

std::vector<SensorPort> sensor_ports(const RobotDescription& d) {
  std::vector<SensorPort> out;
  for (std::size_t s = 0; s < d.sensors.size(); ++s) {
    std::size_t offset = 0;
    for (const auto& g : sensor_groups(d.sensors[s].kind)) {
      for (const auto& declared : d.sensors[s].groups)
        if (declared == g.name) out.push_back({s, offset, g.components.size()});
      offset += g.components.size();
    }
  }
  return out;
}

std::vector<DeviceSignal> sensor_signals(const RobotDescription& d) {
  std::vector<DeviceSignal> out;
  for (const auto& s : d.sensors)
    for (const auto& g : sensor_groups(s.kind))
      for (const auto& declared : s.groups)
        if (declared == g.name) {
          std::string units = g.units;
          units.replace(units.find("LINK"), 4, s.link);
          out.push_back({"sensor." + s.name + "." + g.name, static_cast<std::uint32_t>(g.components.size()), units});
        }
  return out;
}

double yaw_of(const double* R) { return std::atan2(R[3], R[0]); }

MockSensors::MockSensors(const RobotDescription& d) : d_(d) {}

void MockSensors::read(const std::vector<JointState>& state, std::vector<double>& out) const {
  out.clear();
  if (d_.sensors.empty() || !d_.urdf.model) return;
  std::map<std::string, Motion> m;
  const urdf::Link& root = *d_.urdf.model->getRoot();
  m[root.name] = Motion{};
  propagate(d_, root, state, m);
  for (const auto& s : d_.sensors) {
    const Motion& l = m.at(s.link);
    const Eigen::Matrix3d Rt = l.T.linear().transpose();
    out.resize(out.size() + sensor_values(s.kind));
    double* o = out.data() + out.size() - sensor_values(s.kind);
    if (s.kind == SensorKind::force_torque) {
      Eigen::Vector3d f = Eigen::Vector3d::Zero(), t = Eigen::Vector3d::Zero();
      subtree_weight(*d_.urdf.model->getLink(s.link), m, l.T.translation(), f, t);
      const double sign = s.child_to_parent ? 1.0 : -1.0;
      put(sign * (Rt * f), o);
      put(sign * (Rt * t), o);
    } else if (s.kind == SensorKind::imu) {
      const Eigen::Quaterniond q(l.T.linear());
      for (const double x : {q.x(), q.y(), q.z(), q.w()}) *o++ = x;
      put(Rt * l.w, o);
      put(Rt * Eigen::Vector3d(0, 0, kGravity), o);
    } else {
      const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> R = l.T.linear();
      const double yaw = yaw_of(R.data());
      const Eigen::Vector3d v = Eigen::AngleAxisd(-yaw, Eigen::Vector3d::UnitZ()) * l.v;
      for (const double x : {l.T.translation().x(), l.T.translation().y(), yaw, v.x(), v.y(), l.w.z()}) *o++ = x;
    }
  }
}

}  // namespace dca::sim
