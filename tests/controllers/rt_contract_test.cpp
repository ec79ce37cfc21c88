// The real-time contract, measured for every shipped controller (docs/time.md, "Real time"): in steady state a
// controller's MainCalc, its timer and its in-process links (what the real-time thread runs each period)
// allocate nothing, take no lock and fault no page in. Each controller of the registry (the built-ins, the
// package this executable links: RT_CONTRACT_PACKAGE) is made with its default arguments (or those below), its
// inputs fed, started and run for kWarm periods; then kCounted periods are counted (host/rt/contract.h, the
// hooks of tests/support/rt_hooks.cpp), each period from the test sources' writes to the end of its MainCalc.
// A failure names the controller and what it did. A period in which the controller ended (DONE or ABORTED: an
// event for its supervisor, not steady state) is left out.
#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>

#include <dca/package.h>
#include <dca/registry.h>

#include "host/rt/contract.h"
#include "tests/support/controller_fixture.h"

extern "C" const dca::PackageEntry* dca_package_entry_v1();

namespace dca::testing {
namespace {

namespace contract = dca::rt::contract;

constexpr int kWarm = 20;
constexpr int kCounted = 100;

// Arguments for the types whose parameters have no default (after the host).
const std::map<std::string, std::vector<std::string>>& arguments() {
  static const std::map<std::string, std::vector<std::string>> a = {
      {"Constant", {"0.01", "1", "2"}},
      {"Counter", {"0.01"}},
      {"Deadline", {"100"}},
      {"Gain", {"2", "0.01"}},
      {"Sum", {"0.01"}},
      {"Threshold", {"1000"}},
      {"Timer", {"100"}},
      {"GripperControl", {"close"}},
      {"Pid", {"1.0", "2.0"}},
      {"JointSetpoint", {"a", "1.0"}},
      {"EStopButton", {"100"}},
      {"JointPD", {"a b", "100", "10", "effort", "0.01", "1.0", "-1.0"}},
      {"JointTrajectory", {"a b", "0.01", "position", "2", "20", "0.01", "1.0", "0.5", "0.5", "2.0", "1.0", "1.0"}},
  };
  return a;
}

// Inputs whose samples keep a controller running (steady state) where the default would end it at once:
// Type.Input -> {value of every element, elements of a vectorx}; nullopt: left unfed.
struct Sample {
  double value = 0.5;
  int elements = 6;
};
const std::map<std::string, std::optional<Sample>>& samples() {
  static const std::map<std::string, std::optional<Sample>> s = {
      {"DistanceThreshold.Distance", Sample{2.0, 1}},  // far from the threshold
      {"GripperControl.State", Sample{0.0, 1}},         // open: it keeps closing
      {"JointPD.Ref", Sample{0.5, 2}},                  // one per joint
      {"JointPD.RefVel", Sample{0.0, 2}},
      {"JointTrajectory.Waypoints", std::nullopt},      // its own waypoints
  };
  return s;
}

// A controller that breaks the contract on purpose: the test must name it.
class AllocatesEachTick final : public PeriodicController {
  DCA_CONTROLLER(AllocatesEachTick)
  void MainCalc() override {
    held_.push_back(std::make_unique<int>(1));  // one allocation per period (and the vector's growth)
    held_.pop_back();
  }
  std::vector<std::unique_ptr<int>> held_;
};

Manifest AllocatesEachTick::Describe() {
  return {.type = "AllocatesEachTick", .doc = "allocates in each MainCalc (a test's)", .params = {PeriodParam(0.01)},
          .ends = Ending::Never()};
}

AllocatesEachTick::AllocatesEachTick(const ControllerContext& ctx) : PeriodicController(ctx) {}

DCA_REGISTER_CONTROLLER(AllocatesEachTick);

// Types left out, and why.
const std::set<std::string>& left_out() {
  static const std::set<std::string> s = {
      "Crash",              // it dies or hangs by design (fault tests)
      "AllocatesEachTick",  // this test's own, measured below
  };
  return s;
}

void add_package_types() {
  static const bool added = [] {
    Registry staged;
    dca_package_entry_v1()->add_types(staged);
    std::string error;
    if (!Registry::global().adopt(std::move(staged), RT_CONTRACT_PACKAGE, &error)) throw std::logic_error(error);
    return true;
  }();
  (void)added;
}

class RtContract : public ControllerFixture {
 protected:
  struct Fed {
    Output* out;
    PortSpec spec;
    Eigen::VectorXd sample;  // made once: writing it allocates nothing
    double base = 0.5;
  };

  // Feeds each numeric input of `m` from a test source of its own (value inputs are left empty).
  std::vector<Fed> feed_inputs(const Manifest& m, const std::string& name) {
    std::vector<Fed> fed;
    for (const auto& in : m.inputs) {
      if (in.type == PortType::Value) continue;
      const auto given = samples().find(m.type + "." + in.name);
      if (given != samples().end() && !given->second) continue;
      const Sample sample = given == samples().end() ? Sample{} : *given->second;
      PortSpec s = in;
      s.name = m.type + "." + in.name;  // a source of its own per controller
      s.device.clear();
      s.trigger = false;
      s.actuator = false;
      fed.push_back({&feed(s, name, in.name), s, Eigen::VectorXd::Zero(s.size ? s.size : sample.elements),
                     sample.value});
    }
    return fed;
  }

  static void write(Fed& f, int tick) {
    const double v = f.base + 0.01 * (tick % 7);
    if (f.spec.type == PortType::Scalar) {
      f.out->write(v);
    } else {
      f.sample.setConstant(v);
      f.out->write(f.sample);
    }
  }

  // One period: the sources' samples, then the clock to the next tick.
  void period(std::vector<Fed>& fed, int tick) {
    for (auto& f : fed) write(f, tick);
    timers.advance_to(timers.now() + kTick);
  }

  // "" when `type` kept the contract, else what it did.
  std::string measure(const Manifest& m) {
    const std::string name = "/rt/" + m.type;
    const auto a = arguments().find(m.type);
    auto& c = make(m.package.empty() ? m.type : m.package + "." + m.type,
                   a == arguments().end() ? std::vector<std::string>{} : a->second, name);
    auto fed = feed_inputs(m, name);
    ep.activate("s");
    if (const auto e = started(c); !e.empty()) return m.type + ": did not start: " + e;
    for (int i = 0; i < kWarm; ++i) period(fed, i);
    contract::Counts total;
    int counted = 0;
    for (int i = 0; i < kCounted && c.state() == Controller::State::Running; ++i) {
      contract::enter();
      for (auto& f : fed) write(f, i);  // the in-process links (and a triggered MainCalc) are counted too
      timers.advance_to(timers.now() + kTick);
      const auto n = contract::counts();
      contract::leave();
      if (c.state() != Controller::State::Running) break;  // it ended in this period: an event, left out
      total.allocations += n.allocations;
      total.locks += n.locks;
      total.page_faults += n.page_faults;
      ++counted;
    }
    c.halt();  // the shared clock runs only the next controller's timer
    std::printf("%-22s %3d periods counted, %llu MainCalc%s%s\n", m.type.c_str(), counted,
                static_cast<unsigned long long>(c.ticks()), events.empty() ? "" : "; ended: ",
                events.empty() ? "" : (events.back().second.reason.empty() ? "DONE" : events.back().second.reason.c_str()));
    events.clear();
    std::ostringstream why;
    if (counted == 0) why << m.type << ": no period of steady state (it ended at once: give it other inputs)";
    // (under ASan a first touch of its shadow memory is a page fault the controller did not cause: the optimised
    // build asserts page faults, this one allocations and locks)
#ifdef DCA_SANITIZE
    const std::uint64_t faults = 0;
#else
    const std::uint64_t faults = total.page_faults;
#endif
    if (total.allocations || total.locks || faults)
      why << m.type << ": " << total.allocations << " allocations, " << total.locks << " locks, "
          << total.page_faults << " page faults in " << counted << " periods of steady state";
    return why.str();
  }

};

// The test's name says which package's controllers it measures (one CTest name per executable).
TEST_F(RtContract, RT_CONTRACT_TEST) {
  ASSERT_TRUE(contract::hooked());
  add_package_types();
  int measured = 0;
  for (const auto* m : Registry::global().all()) {
    if (left_out().count(m->type)) continue;
    std::string why;
    try {
      why = measure(*m);
    } catch (const std::exception& e) {
      why = m->type + ": " + e.what();
    }
    EXPECT_EQ(why, "") << "the controller " << m->type << " breaks the real-time contract";
    ++measured;
  }
  EXPECT_GT(measured, 0);
}

#if RT_CONTRACT_SELF_TEST  // in one of the two executables
TEST_F(RtContract, NamesTheControllerThatAllocates) {
  ASSERT_TRUE(contract::hooked());
  const std::string why = measure(*Registry::global().manifest("AllocatesEachTick"));
  // (its page faults are left out: they follow from its allocations, and under ASan, whose quarantine hands out
  // fresh memory, there are some)
  EXPECT_EQ(why.rfind("AllocatesEachTick: 100 allocations, 0 locks, ", 0), 0u) << why;
}
#endif

}  // namespace
}  // namespace dca::testing
