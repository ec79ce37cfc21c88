#include "controllers/door/thresholds.h"

#include "controllers/registry.h"

namespace dca::door {

Manifest DistanceThreshold::Describe() {
  return {"DistanceThreshold", "DONE(distance) when Distance falls to the threshold",
          {scalar_port("Distance", "m")}, {},
          {ParamSpec::Number("distance", "0.7", "the threshold, m"), PeriodParam()},
          Ending::Done()};
}
DistanceThreshold::DistanceThreshold(const ControllerContext& ctx)
    : PeriodicController(ctx), distance_(input("Distance")), level_(positive("distance")) {}
void DistanceThreshold::MainCalc() {
  if (distance_.take_latest()) {
    const double d = distance_.scalar();
    if (d <= level_) Done(d);
  }
}

Manifest ForceThreshold::Describe() {
  return {"ForceThreshold", "DONE(|f - f0|) when the force departs from its value at the start",
          {robot::WrenchPort()}, {},
          {ParamSpec::Number("force", "6", "the threshold, N"),
           ParamSpec::Optional("samples", "integer", "3", "consecutive samples above the threshold"),
           ParamSpec::Number("settle", "0.3",
                               "s after the start during which f0 is learnt (smoothed) and nothing fires"),
           PeriodParam()},
          Ending::Done()};
}
ForceThreshold::ForceThreshold(const ControllerContext& ctx)
    : PeriodicController(ctx), wrench_(input("Wrench")), level_(positive("force")), settle_(non_negative("settle")),
      need_(integer("samples")) {
  if (need_ < 1) throw bad_param("samples must be at least 1");
}
void ForceThreshold::Init() {
  above_ = 0;
  have_bias_ = false;
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
  if (to_seconds(now() - started()) < settle_) {
    bias_ += 0.2 * (f - bias_);
    return;
  }
  const double d = (f - bias_).norm();
  above_ = d > level_ ? above_ + 1 : 0;
  if (above_ >= need_) Done(d);
}

DCA_REGISTER_CONTROLLER(DistanceThreshold);
DCA_REGISTER_CONTROLLER(ForceThreshold);

}  // namespace dca::door
