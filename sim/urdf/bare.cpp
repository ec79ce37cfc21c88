#include "sim/urdf/bare.h"

#include "sim/urdf/description.h"
#include "sim/urdf/integrate.h"
#include "sim/urdf_loader.h"

namespace dca::sim {

struct BareUrdf::Impl {
  SimTK::MultibodySystem system;
  SimTK::SimbodyMatterSubsystem matter{system};
  SimTK::GeneralForceSubsystem forces{system};
  SimTK::Force::UniformGravity gravity{forces, matter, SimTK::Vec3(0, 0, -9.81)};
  SimTK::State state;
  SimTK::Vector qdot;
  double period = 1e-3;
};

BareUrdf::BareUrdf(const std::string& path, double period) : impl_(std::make_unique<Impl>()) {
  const RobotDescription d = load_description(path);
  LoaderOptions options;
  options.period = period;
  impl_->period = period;
  add_urdf(impl_->matter, impl_->forces, d.urdf, impl_->matter.updGround(), SimTK::Transform(), options);
  impl_->state = impl_->system.realizeTopology();
  impl_->system.realize(impl_->state, SimTK::Stage::Velocity);
}

BareUrdf::~BareUrdf() = default;

void BareUrdf::step() { euler_step(impl_->system, impl_->matter, impl_->state, impl_->period, impl_->qdot); }

double BareUrdf::q0() const { return impl_->state.getNQ() > 0 ? impl_->state.getQ()[0] : 0.0; }

}  // namespace dca::sim
