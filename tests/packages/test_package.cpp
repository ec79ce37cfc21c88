// The controller packages of the package tests (tests/packages/CMakeLists.txt builds one per variant): one type,
// named PKG_TYPE, `PKG_TYPE(host, k=2, period=0)`: in In, out Out = k * In (event-driven by default). Variants
// break it on purpose: PKG_MISSING_SYMBOL calls a function no one defines, PKG_THROW_IN_CONSTRUCTOR and
// PKG_THROW_IN_INIT throw from the constructor or on_configure, PKG_POSITIVE_K takes k as positive (a bad
// parameter: its node fails to start), PKG_BAD_PORT binds an input "SetPoint", a name its manifest lacks,
// PKG_CRASH_IN_STATIC_INIT faults in a static initialiser,
// PKG_STDERR writes k lines "line N of PKG_TYPE" to stderr at its first tick, then ends DONE(k). A rebuilt pkg_ok
// (tests/packages/CMakeLists.txt, lib/variants/): PKG_DEFAULT_K another default k, PKG_OUT another name of Out,
// PKG_CRASH_ON_SAMPLE a bad release that aborts (SIGABRT) at its first sample (a rolling upgrade's failed canary).
#include <sys/mman.h>

#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#include <dca/controller.h>
#include <dca/registry.h>

#define PKG_STR2(x) #x
#define PKG_STR(x) PKG_STR2(x)

#ifdef PKG_MISSING_SYMBOL
namespace dca {
double missing_for_tests(double x);  // defined nowhere: the loader must name it
}  // namespace dca
#endif


namespace {

const dca::InSpec<double> kIn{.name = "In", .trigger = true};
#ifndef PKG_OUT
#define PKG_OUT Out
#endif
#ifndef PKG_DEFAULT_K
#define PKG_DEFAULT_K 2
#endif
const dca::OutSpec<double> kOut{.name = PKG_STR(PKG_OUT)};
#ifdef PKG_POSITIVE_K
const dca::Param<double> kK{.name = "k", .doc = "the gain", .def = PKG_DEFAULT_K, .above = 0};
#else
const dca::Param<double> kK{.name = "k", .doc = "the gain", .def = PKG_DEFAULT_K};
#endif
#ifdef PKG_BAD_PORT
const dca::InSpec<double> kBadPort{.name = "SetPoint"};
#endif

class PKG_TYPE final : public dca::PeriodicController {
  DCA_CONTROLLER(PKG_TYPE)
  void on_configure() override {
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
    double x = 0;
    if (in_.read(x) != dca::Read::New) return;
#ifdef PKG_CRASH_ON_SAMPLE
    std::abort();
#endif
    double y = k_ * x;
#ifdef PKG_MISSING_SYMBOL
    y = dca::missing_for_tests(y);
#endif
    out_.write(y);
  }

  dca::In<double> in_;
  dca::Out<double> out_;
  double k_;
#ifdef PKG_STDERR
  bool said_ = false;
#endif
};

dca::Manifest PKG_TYPE::Describe() {
  return {.type = PKG_STR(PKG_TYPE), .doc = "Out = k * In (a test package's type)", .inputs = {kIn}, .outputs = {kOut},
          .params = {kK, PeriodParam(0, "seconds between ticks; 0: on each sample", Period::ZeroIsEventDriven)}};
}

PKG_TYPE::PKG_TYPE(const dca::ControllerContext& ctx)
    : PeriodicController(ctx, Period::ZeroIsEventDriven), in_(port(kIn)), out_(port(kOut)), k_(param(kK)) {
#ifdef PKG_BAD_PORT
  (void)port(kBadPort);
#endif
#ifdef PKG_THROW_IN_CONSTRUCTOR
  throw std::runtime_error("cannot open the device /dev/nonexistent");
#endif
}

DCA_REGISTER_CONTROLLER(PKG_TYPE);

#ifdef PKG_CRASH_IN_STATIC_INIT
// A static initialiser that faults for real (a store to a read-only page): dlopen runs it.
const int kCrash = [] {
  void* page = ::mmap(nullptr, 4096, PROT_READ, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (page != MAP_FAILED) *static_cast<volatile int*>(page) = 1;
  return 0;
}();
#endif

}  // namespace

// dca's entry point, in this translation unit (one per test package keeps the build short).
#include "dca_package_entry.cpp"
