#include "sim/urdf/frames.h"

#include <urdf_model/model.h>

#include <Eigen/Geometry>

namespace dca::sim {
namespace {

// Visits the joints below `link`, parents first.
template <class F>
void each_joint(const urdf::Link& link, const F& f) {
  for (std::size_t i = 0; i < link.child_joints.size(); ++i) {  // child_links[i] is child_joints[i]'s child
    f(*link.child_joints[i]);
    if (i < link.child_links.size() && link.child_links[i]) each_joint(*link.child_links[i], f);
  }
}

const urdf::Link* root_of(const RobotDescription& d) {
  return d.urdf.model ? d.urdf.model->getRoot().get() : nullptr;
}

}  // namespace

std::vector<frames::Frame> link_frames(const RobotDescription& d) {
  std::vector<frames::Frame> out;
  const urdf::Link* root = root_of(d);
  if (!root) return out;
  if (root->name != "world") out.push_back({"world", root->name});
  each_joint(*root, [&](const urdf::Joint& j) { out.push_back({j.parent_link_name, j.child_link_name}); });
  return out;
}

std::vector<std::string> frame_joints(const RobotDescription& d) {
  std::vector<std::string> out;
  const urdf::Link* root = root_of(d);
  if (!root) return out;
  if (root->name != "world") out.emplace_back();
  each_joint(*root, [&](const urdf::Joint& j) { out.push_back(j.name); });
  return out;
}

void joint_frames(const RobotDescription& d, const std::vector<double>& q, double* out) {
  const urdf::Link* root = root_of(d);
  if (!root) return;
  auto put = [&out](const Eigen::Vector3d& p, const Eigen::Quaterniond& r) {
    const double v[7] = {p.x(), p.y(), p.z(), r.x(), r.y(), r.z(), r.w()};
    for (const double x : v) *out++ = x;
  };
  if (root->name != "world") put(Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity());
  each_joint(*root, [&](const urdf::Joint& j) {
    const auto& o = j.parent_to_joint_origin_transform;
    const Eigen::Vector3d p(o.position.x, o.position.y, o.position.z);
    const Eigen::Quaterniond r(o.rotation.w, o.rotation.x, o.rotation.y, o.rotation.z);
    const JointSpec* spec = d.joint(j.name);
    const double x = spec ? q[static_cast<std::size_t>(spec - d.joints.data())] : 0.0;
    Eigen::Vector3d axis(j.axis.x, j.axis.y, j.axis.z);
    axis = axis.norm() > 0 ? axis.normalized() : Eigen::Vector3d::UnitX();
    if (spec && spec->linear) return put(p + r * (axis * x), r);
    if (spec) return put(p, (r * Eigen::Quaterniond(Eigen::AngleAxisd(x, axis))).normalized());
    put(p, r.normalized());
  });
}

}  // namespace dca::sim
