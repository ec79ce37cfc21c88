// The controller packages of the package tests (tests/packages/CMakeLists.txt builds one per variant): one type,
// named PKG_TYPE, `PKG_TYPE(host, k=2, period=0)`: in In, out Out = k * In (event-driven by default). Variants
// break it on purpose: PKG_MISSING_SYMBOL calls a function no one defines, PKG_THROW_IN_CONSTRUCTOR and
// PKG_THROW_IN_INIT throw from the constructor or Init, PKG_POSITIVE_K takes k with positive("k") (a bad
// parameter: its node fails to start), PKG_BAD_PORT asks for input("SetPoint"), a name its manifest lacks,
// PKG_STDERR writes k lines "line N of PKG_TYPE" to stderr at its first tick, then ends DONE(k).
#include <cstdio>
#include <stdexcept>

#include "controllers/controller.h"
#include "controllers/registry.h"

#define PKG_STR2(x) #x
#define PKG_STR(x) PKG_STR2(x)

#ifdef PKG_MISSING_SYMBOL
namespace dca {
double missing_for_tests(double x);  // defined nowhere: the loader must name it
}  // namespace dca
#endif

#ifdef PKG_POSITIVE_K
#define PKG_K positive
#else
#define PKG_K number
#endif

namespace {

class PKG_TYPE final : public dca::PeriodicController {
  DCA_CONTROLLER(PKG_TYPE)
  void Init() override {
#ifdef PKG_THROW_IN_INIT
    throw std::runtime_error("calibration file /nonexistent/cal.yaml is missing");
#endif
  }
  void MainCalc() override {
#ifdef PKG_STDERR
    if (said_) return;
    said_ = true;
    for (int i = 1; i <= static_cast<int>(k_); ++i) std::fprintf(stderr, "line %d of %s\n", i, PKG_STR(PKG_TYPE));
    return Done(k_);
#endif
    if (!in_.take_latest()) return;
    double y = k_ * in_.scalar();
#ifdef PKG_MISSING_SYMBOL
    y = dca::missing_for_tests(y);
#endif
    out_.write(y);
  }

  dca::Input& in_;
  dca::Output& out_;
  double k_;
#ifdef PKG_STDERR
  bool said_ = false;
#endif
};

dca::Manifest PKG_TYPE::Describe() {
  return {PKG_STR(PKG_TYPE), "Out = k * In (a test package's type)", {dca::scalar_port("In")},
          {dca::scalar_port("Out")},
          {dca::ParamSpec::Number("k", "2", "the gain"), PeriodParam("0", "seconds between ticks; 0: on each sample")}};
}

PKG_TYPE::PKG_TYPE(const dca::ControllerContext& ctx)
    : PeriodicController(ctx, Period::ZeroIsEventDriven), in_(trigger("In")), out_(output("Out")), k_(PKG_K("k")) {
#ifdef PKG_BAD_PORT
  input("SetPoint");
#endif
#ifdef PKG_THROW_IN_CONSTRUCTOR
  throw std::runtime_error("cannot open the device /dev/nonexistent");
#endif
}

DCA_REGISTER_CONTROLLER(PKG_TYPE);

}  // namespace

// dca's entry point, in this translation unit (one per test package keeps the build short).
#include "cmake/dca_package_entry.cpp"
