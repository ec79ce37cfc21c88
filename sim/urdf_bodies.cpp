#include "sim/urdf_bodies.h"

#include "sim/urdf_loader.h"

namespace dca::sim {

struct UrdfBodies::Impl {
  SimTK::MultibodySystem system;
  SimTK::SimbodyMatterSubsystem matter{system};
  SimTK::GeneralForceSubsystem forces{system};
  LoadedUrdf loaded;
  SimTK::State state;
};

UrdfBodies::UrdfBodies(const std::string& path) : impl_(std::make_unique<Impl>()) {
  const ParsedUrdf parsed = parse_urdf_file(path);
  impl_->loaded = add_urdf(impl_->matter, impl_->forces, parsed, impl_->matter.updGround(), SimTK::Transform());
  impl_->state = impl_->system.realizeTopology();
  impl_->system.realizeModel(impl_->state);
}

UrdfBodies::~UrdfBodies() = default;

std::vector<std::string> UrdfBodies::joints() const {
  std::vector<std::string> names;
  for (const auto& j : impl_->loaded.joints) names.push_back(j.name);
  return names;
}

void UrdfBodies::set_q(const std::string& joint, const std::vector<double>& q) {
  const LoadedJoint* j = impl_->loaded.joint(joint);
  if (!j) throw UrdfError(impl_->loaded.file + ": no moving joint '" + joint + "'");
  if (static_cast<int>(q.size()) != j->nq)
    throw UrdfError(impl_->loaded.file + ": joint '" + joint + "' has " + std::to_string(j->nq) + " coordinates");
  const SimTK::MobilizedBody& m = impl_->matter.getMobilizedBody(j->body);
  for (int i = 0; i < j->nq; ++i) m.setOneQ(impl_->state, i, q[static_cast<size_t>(i)]);
}

Eigen::Isometry3d UrdfBodies::link_pose(const std::string& link) const {
  impl_->system.realize(impl_->state, SimTK::Stage::Position);
  const SimTK::Transform X = impl_->loaded.link_pose(impl_->matter, impl_->state, link);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T.linear()(r, c) = X.R()[r][c];
    T.translation()(r) = X.p()[r];
  }
  return T;
}

double UrdfBodies::total_mass() const {
  impl_->system.realize(impl_->state, SimTK::Stage::Instance);
  return impl_->matter.calcSystemMass(impl_->state);
}

}  // namespace dca::sim
