#include "door/thresholds.h"

#include <dca/registry.h>
#include "door/ports.h"

namespace dca::door {

namespace {
const InSpec<double> kDistanceIn{.name = "Distance", .units = "m"};
const Param<double> kThresholdDistance{.name = "distance", .doc = "the threshold, m", .def = 0.7, .above = 0};
const Param<double> kThresholdForce{.name = "force", .doc = "the threshold, N", .def = 6, .above = 0};
const Param<std::int64_t> kSamples{.name = "samples", .doc = "consecutive samples above the threshold", .def = 3,
                                   .min = 1};
const Param<double> kSettle{.name = "settle",
                            .doc = "s after the start during which f0 is learnt (smoothed) and nothing fires",
                            .def = 0.3, .min = 0};
}  // namespace

Manifest DistanceThreshold::Describe() {
  return {.type = "DistanceThreshold", .doc = "DONE(distance) when Distance falls to the threshold",
          .inputs = {kDistanceIn}, .params = {kThresholdDistance, PeriodParam()}, .ends = Ending::Done()};
}
DistanceThreshold::DistanceThreshold(const ControllerContext& ctx)
    : PeriodicController(ctx), distance_(port(kDistanceIn)), level_(param(kThresholdDistance)) {}
void DistanceThreshold::MainCalc() {
  double d = 0;
  if (distance_.read(d) == Read::New && d <= level_) Done(d);
}

Manifest ForceThreshold::Describe() {
  return {.type = "ForceThreshold", .doc = "DONE(|f - f0|) when the force departs from its value at the start",
          .inputs = {kWrench}, .params = {kThresholdForce, kSamples, kSettle, PeriodParam()}, .ends = Ending::Done()};
}
ForceThreshold::ForceThreshold(const ControllerContext& ctx)
    : PeriodicController(ctx), wrench_(port(kWrench)), level_(param(kThresholdForce)), settle_(param(kSettle)),
      need_(param(kSamples)) {}
void ForceThreshold::on_configure() {
  above_ = 0;
  have_bias_ = false;
}
// The reference f0 is learnt while the run settles: the step that starts this detector often starts with a
// jolt (the base stopping when the previous step ends, the gripper opening), and a reference taken from one
// sample of that jolt fires at once. It is smoothed over the settle time and frozen after it.
void ForceThreshold::MainCalc() {
  if (wrench_.read(w_) != Read::New) return;
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
