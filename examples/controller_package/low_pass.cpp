// LowPass(host, tau, period=0.01, tolerance=0): a first-order low-pass filter on a vector of any size.
//   in  In   vectorx   the signal (the filter follows the latest sample)
//   out Out  vectorx   y += dt / (tau + dt) * (In - y) every period, starting from the first sample
// With tolerance > 0 it ends DONE(the largest |In - Out|) once every element is within tolerance of its input:
// the step has settled.
#include <Eigen/Core>

#include <dca/controller.h>
#include <dca/registry.h>

namespace mylab {

const dca::InSpec<Eigen::VectorXd> kIn{.name = "In"};
const dca::OutSpec<Eigen::VectorXd> kOut{.name = "Out"};
const dca::Param<double> kTau{.name = "tau", .doc = "the time constant (s)", .above = 0};
const dca::Param<double> kTolerance{.name = "tolerance", .doc = "DONE once |In - Out| <= tolerance everywhere (0: never)",
                                    .def = 0, .min = 0};

class LowPass final : public dca::PeriodicController {
  DCA_CONTROLLER(LowPass)
  void on_configure() override { started_ = false; }
  void MainCalc() override;

  dca::In<Eigen::VectorXd> in_;
  dca::Out<Eigen::VectorXd> out_;
  double tau_, tolerance_;
  Eigen::VectorXd x_, y_;
  bool started_ = false;
};

dca::Manifest LowPass::Describe() {
  return {.type = "LowPass",
          .doc = "a first-order low-pass filter: y += dt / (tau + dt) * (In - y)",
          .inputs = {kIn},
          .outputs = {kOut},
          .params = {kTau, PeriodParam(0.01), kTolerance},
          .ends = dca::Ending::Done()};  // if it ends by itself, DONE (settled)
}

LowPass::LowPass(const dca::ControllerContext& ctx)
    : PeriodicController(ctx), in_(port(kIn)), out_(port(kOut)), tau_(param(kTau)), tolerance_(param(kTolerance)) {}

void LowPass::MainCalc() {
  if (in_.read(x_) == dca::Read::None) return;  // x_ takes the sample's size (allocates only when it changes)
  if (!started_ || y_.size() != x_.size()) {
    y_ = Eigen::VectorXd::Zero(x_.size());
    started_ = true;
  }
  const double dt = period();
  y_ += dt / (tau_ + dt) * (x_ - y_);
  out_.write(y_);
  if (tolerance_ > 0 && (x_ - y_).cwiseAbs().maxCoeff() <= tolerance_) Done((x_ - y_).cwiseAbs().maxCoeff());
}

DCA_REGISTER_CONTROLLER(LowPass);

}  // namespace mylab
