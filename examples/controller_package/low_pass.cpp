// LowPass(host, tau, period=0.01, tolerance=0): a first-order low-pass filter on a vector of any size.
//   in  In   vectorx   the signal (the filter follows the latest sample)
//   out Out  vectorx   y += dt / (tau + dt) * (In - y) every period, starting from the first sample
// With tolerance > 0 it ends DONE(the largest |In - Out|) once every element is within tolerance of its input:
// the step has settled.
#include <Eigen/Core>

#include "controllers/controller.h"
#include "controllers/registry.h"

namespace mylab {

class LowPass final : public dca::PeriodicController {
  DCA_CONTROLLER(LowPass)
  void Init() override { started_ = false; }
  void MainCalc() override;

  dca::Input& in_;
  dca::Output& out_;
  double tau_, tolerance_;
  Eigen::VectorXd x_, y_;
  bool started_ = false;
};

dca::Manifest LowPass::Describe() {
  using P = dca::ParamSpec;
  return {"LowPass", "a first-order low-pass filter: y += dt / (tau + dt) * (In - y)",
          {dca::vectorx_port("In")},
          {dca::vectorx_port("Out")},
          {P::Required("tau", "number", "the time constant (s)"), PeriodParam("0.01"),
           P::Number("tolerance", "0", "DONE once |In - Out| <= tolerance everywhere (0: never)")},
          dca::Ending::Done()};  // if it ends by itself, DONE (settled)
}

LowPass::LowPass(const dca::ControllerContext& ctx)
    : PeriodicController(ctx), in_(input("In")), out_(output("Out")), tau_(positive("tau")),
      tolerance_(non_negative("tolerance")) {
  x_.resize(16);  // grown (outside MainCalc's steady state) only for bigger samples
  y_.resize(16);
}

void LowPass::MainCalc() {
  if (in_.take_latest()) {
    const auto s = in_.vector();
    if (!started_ || s.size() != x_.size()) {
      x_ = s;
      y_ = Eigen::VectorXd::Zero(s.size());
      started_ = true;
    } else {
      x_ = s;
    }
  }
  if (!started_) return;
  const double dt = period();
  y_ += dt / (tau_ + dt) * (x_ - y_);
  out_.write(y_);
  if (tolerance_ > 0 && (x_ - y_).cwiseAbs().maxCoeff() <= tolerance_) Done((x_ - y_).cwiseAbs().maxCoeff());
}

DCA_REGISTER_CONTROLLER(LowPass);

}  // namespace mylab
