// Controller base class and registry: manifests, ports by name, parameters, life cycle, lock-step time.
#include <dca/controller.h>

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include <boost/asio/io_context.hpp>

#include <dca/registry.h>
#include "tests/support/controller_fixture.h"

namespace {

// A controller that overrides every hook and calls no base: the public operations still do the safety duties.
const dca::OutSpec<Eigen::Matrix<double, 3, 1>> kHookVel{.name = "Vel", .actuator = true};
const dca::OutSpec<double> kHookLevel{.name = "Level", .actuator = true};
const dca::OutSpec<double> kHookLog{.name = "Log"};  // not an actuator: left as it is
int hook_calls = 0;

class Hooks final : public dca::PeriodicController {
  DCA_CONTROLLER(Hooks)
  void on_configure() override { ++hook_calls; }
  void on_start(const msgpack::object&) override { ++hook_calls; }
  void on_halt() override { ++hook_calls; }
  void MainCalc() override {
    vel_.write(Eigen::Vector3d(1, 2, 3));
    level_.write(4.0);
    log_.write(5.0);
  }

  dca::Out<Eigen::Matrix<double, 3, 1>> vel_;
  dca::Out<double> level_, log_;
};
dca::Manifest Hooks::Describe() {
  return {.type = "TestHooks", .outputs = {kHookVel, kHookLevel, kHookLog}, .params = {PeriodParam()}};
}
Hooks::Hooks(const dca::ControllerContext& ctx)
    : PeriodicController(ctx), vel_(port(kHookVel)), level_(port(kHookLevel)), log_(port(kHookLog)) {}
DCA_REGISTER_CONTROLLER(Hooks);

// Parameters with ranges and allowed values.
const dca::Param<double> kTau{.name = "tau", .doc = "s", .def = 0.1, .above = 0};
const dca::Param<double> kRatio{.name = "ratio", .def = 0.5, .min = 0, .max = 1, .live = true};  // no hook
const dca::Param<std::int64_t> kCount{.name = "count", .def = 1, .min = 1};
const dca::Param<std::string> kMode{.name = "mode", .def = "fast", .allowed = {"fast", "slow", "off"}};
const dca::Param<std::vector<double>> kGains{.name = "gains", .max = 10};

class Ranges final : public dca::Controller {
  DCA_CONTROLLER(Ranges)
};
dca::Manifest Ranges::Describe() {
  return {.type = "TestRanges", .params = {kTau, kRatio, kCount, kMode, kGains}};
}
Ranges::Ranges(const dca::ControllerContext& ctx) : Controller(ctx) {}
DCA_REGISTER_CONTROLLER(Ranges);

// Live parameters (docs/packages.md): gain and mode change while it runs, through its hook, which refuses a gain
// of 7 and throws on 8 (after taking it: the base has it read the old value again); fixed is not live.
const dca::OutSpec<double> kLiveOut{.name = "Out"};
const dca::Param<double> kLiveGain{.name = "gain", .def = 1, .min = 0, .max = 10, .live = true};
const dca::Param<std::string> kLiveMode{.name = "mode", .def = "a", .allowed = {"a", "b"}, .live = true};
const dca::Param<double> kFixed{.name = "fixed", .def = 1};

class Live final : public dca::PeriodicController {
  DCA_CONTROLLER(Live)
  std::string on_parameter(std::string_view name) override {
    if (name == kLiveMode.name) mode_ = param(kLiveMode);
    if (name != kLiveGain.name) return "";
    const double g = param(kLiveGain);
    if (g == 7) return "7 brings bad luck";
    gain_ = g;
    if (g == 8) throw std::runtime_error("eight is too many");
    return "";
  }
  void MainCalc() override { out_.write(gain_); }

  dca::Out<double> out_;
  double gain_;
  std::string mode_;
};
dca::Manifest Live::Describe() {
  return {.type = "TestLive", .outputs = {kLiveOut}, .params = {kLiveGain, kLiveMode, kFixed, PeriodParam()}};
}
Live::Live(const dca::ControllerContext& ctx)
    : PeriodicController(ctx), out_(port(kLiveOut)), gain_(param(kLiveGain)), mode_(param(kLiveMode)) {}
DCA_REGISTER_CONTROLLER(Live);

class ControllerTest : public dca::testing::ControllerFixture {
 protected:
  /// An instance outside the fixture's endpoint (its events not collected).
  std::unique_ptr<dca::Controller> create(const std::string& type, std::vector<std::string> params,
                                          const std::string& name = "/t") {
    return dca::Registry::global().create(type, {name, "local", std::move(params), &timers, nullptr});
  }

  /// The issue's lock-step test: three controllers at different rates tick in the right order, the same every run.
  static std::vector<std::string> lock_step_trace() {
    boost::asio::io_context io;
    dca::TimerServer ts(io, dca::ClockKind::Simulated);
    std::vector<std::string> trace;
    ts.on_fire = [&](const std::string& name, dca::Nanos deadline) {
      trace.push_back(name + "@" + std::to_string(deadline / kMs));
    };
    std::vector<std::unique_ptr<dca::Controller>> cs;
    for (auto [name, period] : {std::pair{"/fast", "0.001"}, {"/mid", "0.002"}, {"/slow", "0.003"}})
      cs.push_back(dca::Registry::global().create("Counter", {name, "local", {period}, &ts, nullptr}));
    for (auto& c : cs) EXPECT_EQ(started(*c), "");
    while (ts.now() < 6 * kMs) {
      const auto next = ts.next_deadline();
      EXPECT_TRUE(next);
      // Every controller due at this tick finishes its MainCalc inside advance_to: only then does time move on.
      const auto before = trace.size();
      ts.advance_to(*next);
      EXPECT_GT(trace.size(), before);
      EXPECT_EQ(ts.now(), *next);
    }
    for (auto& c : cs) c->halt();
    return trace;
  }
};

TEST_F(ControllerTest, RegistryListsTheBuiltinsWithoutAnInstance) {
  std::vector<std::string> names;
  for (const auto* m : dca::Registry::global().all()) names.push_back(m->type);
  for (const char* t : {"Constant", "Counter", "Crash", "Deadline", "Gain", "Sum", "TestHooks", "Threshold", "Timer"})
    EXPECT_NE(std::find(names.begin(), names.end(), t), names.end()) << t;
  EXPECT_TRUE(std::is_sorted(names.begin(), names.end()));
  const auto* sum = dca::Registry::global().manifest("Sum");
  ASSERT_NE(sum, nullptr);
  ASSERT_EQ(sum->inputs.size(), 2u);
  EXPECT_EQ(sum->inputs[1].name, "In2");
  EXPECT_EQ(sum->outputs[0].type, dca::PortType::VectorX);
}

TEST_F(ControllerTest, EveryManifestPortExistsOnAnInstance) {
  for (const auto* m : dca::Registry::global().all()) {
    std::vector<std::string> params;
    for (const auto& p : m->params)
      if (p.required) params.push_back(p.type != "string" ? "1" : p.name == "action" ? "open" : "x");
    auto c = create(m->type, params);
    for (const auto& p : m->inputs) EXPECT_NE(c->ports().find_input(p.name), nullptr) << m->type << "." << p.name;
    for (const auto& p : m->outputs) EXPECT_NE(c->ports().find_output(p.name), nullptr) << m->type << "." << p.name;
    EXPECT_EQ(c->ports().inputs().size(), m->inputs.size());
    EXPECT_EQ(c->ports().outputs().size(), m->outputs.size());
  }
}

TEST_F(ControllerTest, UnknownTypeListsTheKnownOnes) {
  const std::string e = make_error("Gian", {"1"}, "/t");
  EXPECT_NE(e.find("unknown controller type 'Gian'; types are: "), std::string::npos);
  EXPECT_NE(e.find("Gain"), std::string::npos);
}

TEST_F(ControllerTest, BadParametersNameTheControllerAndTheParameter) {
  EXPECT_EQ(make_error("Timer", {"soon"}, "/sys/t"), "Timer /sys/t: parameter 'seconds' must be a number, got 'soon'");
  EXPECT_EQ(make_error("Timer", {}, "/sys/t"), "Timer /sys/t: parameter 1 'seconds' is required");
  EXPECT_THROW(create("Timer", {"1", "2"}), std::invalid_argument);
  EXPECT_THROW(create("Threshold", {"1", "sideways"}), std::invalid_argument);
}

TEST_F(ControllerTest, HooksWithoutBaseCallsStillStartTheTimerAndZeroTheActuators) {
  hook_calls = 0;
  auto& c = make("TestHooks", {"0.01"}, "/h");
  ASSERT_EQ(started(c), "");  // configure + start: on_configure, on_start
  EXPECT_EQ(hook_calls, 2);
  timers.advance_to(30 * kMs);
  EXPECT_EQ(c.ticks(), 3u);  // the timer runs: on_start started nothing
  EXPECT_EQ(latest(c, "Vel"), Eigen::Vector3d(1, 2, 3));
  c.halt();
  EXPECT_EQ(hook_calls, 3);
  EXPECT_EQ(c.state(), dca::Controller::State::Stopped);
  EXPECT_EQ(latest(c, "Vel"), Eigen::Vector3d::Zero());  // on_halt wrote nothing: the base did
  EXPECT_EQ(latest(c, "Level")[0], 0.0);
  EXPECT_EQ(latest(c, "Log")[0], 5.0);  // not an actuator
  timers.advance_to(60 * kMs);
  EXPECT_EQ(c.ticks(), 3u);  // and the timer stopped
  // An abort (Done/Abort from inside, here a restart's halt) leaves them at zero the same way.
  ASSERT_EQ(started(c), "");
  timers.advance_to(70 * kMs);
  EXPECT_EQ(latest(c, "Level")[0], 4.0);
  c.halt();
  EXPECT_EQ(latest(c, "Level")[0], 0.0);
}

TEST_F(ControllerTest, TheStatesChangeOnlyByTheirTransitions) {
  using S = dca::Controller::State;
  const S all[] = {S::Idle, S::Ready, S::Running, S::Finished, S::Stopped};
  std::vector<std::string> legal;
  for (S from : all)
    for (S to : all)
      if (dca::Controller::legal(from, to))
        legal.push_back(std::string(dca::Controller::to_string(from)) + ">" + std::string(dca::Controller::to_string(to)));
  EXPECT_EQ(legal, (std::vector<std::string>{"idle>ready", "ready>ready", "ready>running", "ready>stopped",
                                             "running>finished", "running>stopped", "finished>ready",
                                             "stopped>ready"}));
  auto& c = make("Timer", {"0.005"}, "/t");
  c.halt();  // nothing to stop: no change
  EXPECT_EQ(c.state(), S::Idle);
  ASSERT_EQ(started(c), "");
  EXPECT_EQ(started(c), "Timer /t is already running");  // refused, and still running
  EXPECT_EQ(c.state(), S::Running);
  timers.advance_to(10 * kMs);
  EXPECT_EQ(c.state(), S::Finished);
  c.halt();  // finished: nothing to stop
  EXPECT_EQ(c.state(), S::Finished);
  EXPECT_EQ(events.size(), 1u);
}

TEST_F(ControllerTest, ParametersAreCheckedAgainstTheirRangesWhenSet) {
  EXPECT_EQ(make_error("TestRanges", {"-0.005"}, "/r"), "TestRanges /r: parameter 'tau' must be positive, got -0.005");
  EXPECT_EQ(make_error("TestRanges", {"1", "2"}, "/r"), "TestRanges /r: parameter 'ratio' must be in [0, 1], got 2");
  EXPECT_EQ(make_error("TestRanges", {"1", "1", "0"}, "/r"), "TestRanges /r: parameter 'count' must be at least 1, got 0");
  EXPECT_EQ(make_error("TestRanges", {"1", "1", "2.5"}, "/r"),
            "TestRanges /r: parameter 'count' must be an integer, got '2.5'");
  EXPECT_EQ(make_error("TestRanges", {"1", "1", "1", "fastest"}, "/r"),
            "TestRanges /r: parameter 'mode' must be fast, slow or off, got 'fastest'");
  EXPECT_EQ(make_error("TestRanges", {"1", "1", "1", "off", "3", "11"}, "/r"),
            "TestRanges /r: parameter 'gains' (argument 6) must be at most 10, got 11");
  EXPECT_EQ(make_error("TestRanges", {"1", "0", "1", "slow", "3", "10"}, "/r"), "no error");
  EXPECT_EQ(make_error("TestRanges", {}, "/r"), "no error");  // the defaults are in range
  const auto* m = dca::Registry::global().manifest("TestRanges");
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(m->params[0].default_value, "0.1");
  EXPECT_EQ(m->params[3].allowed, (std::vector<std::string>{"fast", "slow", "off"}));
  EXPECT_TRUE(m->params[4].variadic);
}

// set_parameter: between two ticks, the next MainCalc sees the new value; the old one stays when refused.
static std::string set(dca::Controller& c, std::string_view name, const std::string& text) {
  std::string error;
  return c.set_parameter(name, text, &error) ? "" : error;
}

TEST_F(ControllerTest, ALiveParameterTakesEffectAtTheNextTick) {
  auto& c = make("TestLive", {}, "/l");  // gain absent: its default, 1
  ASSERT_EQ(started(c), "");
  timers.advance_to(10 * kMs);
  EXPECT_EQ(latest(c, "Out")[0], 1.0);
  EXPECT_EQ(set(c, "gain", "2.5"), "");
  EXPECT_EQ(latest(c, "Out")[0], 1.0);  // nothing runs until the next tick
  timers.advance_to(20 * kMs);
  EXPECT_EQ(latest(c, "Out")[0], 2.5);
  EXPECT_EQ(set(c, "mode", "b"), "");
  EXPECT_EQ(c.state(), dca::Controller::State::Running);
  const auto* m = dca::Registry::global().manifest("TestLive");
  ASSERT_NE(m, nullptr);
  EXPECT_TRUE(m->params[0].live);
  EXPECT_FALSE(m->params[2].live);
}

TEST_F(ControllerTest, ALiveParameterRefusedByItsHookKeepsTheOldValue) {
  auto& c = make("TestLive", {"3"}, "/l");
  ASSERT_EQ(started(c), "");
  EXPECT_EQ(set(c, "gain", "7"), "TestLive /l: parameter 'gain' not changed: 7 brings bad luck");
  timers.advance_to(10 * kMs);
  EXPECT_EQ(latest(c, "Out")[0], 3.0);
  EXPECT_EQ(set(c, "gain", "8"), "TestLive /l: parameter 'gain' not changed: on_parameter failed: eight is too many");
  timers.advance_to(20 * kMs);
  EXPECT_EQ(latest(c, "Out")[0], 3.0);  // the hook took 8, then threw: it read 3 again
  EXPECT_EQ(set(c, "gain", "4"), "");  // and the next change is taken as any other
  timers.advance_to(30 * kMs);
  EXPECT_EQ(latest(c, "Out")[0], 4.0);
  // a live parameter of a type without a hook: the base's refuses
  auto& r = make("TestRanges", {}, "/r");
  EXPECT_EQ(set(r, "ratio", "0.25"), "TestRanges /r: parameter 'ratio' not changed: TestRanges has no on_parameter() "
                                     "to take 'ratio'");
}

TEST_F(ControllerTest, AParameterNotLiveOrUnknownIsRefusedByName) {
  auto& c = make("TestLive", {"3", "a", "2"}, "/l");
  ASSERT_EQ(started(c), "");
  EXPECT_EQ(set(c, "fixed", "5"), "TestLive /l: parameter 'fixed' is not live: it changes at the leaf's next start");
  EXPECT_EQ(set(c, "period", "0.02"), "TestLive /l: parameter 'period' is not live: it changes at the leaf's next start");
  EXPECT_EQ(set(c, "gian", "5"), "TestLive /l: no parameter 'gian' (parameters: gain, mode, fixed, period)");
  timers.advance_to(10 * kMs);
  EXPECT_EQ(latest(c, "Out")[0], 3.0);
}

TEST_F(ControllerTest, ALiveValueOutOfRangeOrOfAnotherTypeIsRefusedAsAtConstruction) {
  auto& c = make("TestLive", {"3"}, "/l");
  ASSERT_EQ(started(c), "");
  EXPECT_EQ(set(c, "gain", "11"), "TestLive /l: parameter 'gain' must be in [0, 10], got 11");
  EXPECT_EQ(set(c, "gain", "-1"), "TestLive /l: parameter 'gain' must be in [0, 10], got -1");
  EXPECT_EQ(set(c, "gain", "fast"), "TestLive /l: parameter 'gain' must be a number, got 'fast'");
  EXPECT_EQ(set(c, "mode", "c"), "TestLive /l: parameter 'mode' must be a or b, got 'c'");
  EXPECT_EQ(make_error("TestLive", {"11"}, "/l"), "TestLive /l: parameter 'gain' must be in [0, 10], got 11");
  timers.advance_to(10 * kMs);
  EXPECT_EQ(latest(c, "Out")[0], 3.0);
  EXPECT_EQ(c.state(), dca::Controller::State::Running);
}

TEST_F(ControllerTest, DoneAfterStopIsIgnored) {
  auto* c = &make("Timer", {"0.005"}, "/t");  // its events go to `events`
  ASSERT_EQ(configured(*c), "");
  ASSERT_EQ(started(*c), "");
  EXPECT_EQ(c->state(), dca::Controller::State::Running);
  c->halt();
  timers.advance_to(10 * kMs);
  EXPECT_TRUE(events.empty());
  EXPECT_EQ(c->state(), dca::Controller::State::Stopped);
  // And it can run again after a new init.
  ASSERT_EQ(configured(*c), "");
  ASSERT_EQ(started(*c), "");
  timers.advance_to(20 * kMs);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(c->state(), dca::Controller::State::Finished);
}

TEST_F(ControllerTest, RunTwiceIsRefused) {
  auto c = create("Counter", {"0.001"});
  ASSERT_EQ(started(*c), "");  // run inits first when needed
  EXPECT_EQ(started(*c), "Counter /t is already running");
}

TEST_F(ControllerTest, LockStepClockTicksThreeControllersInOrderEveryRun) {
  const auto first = lock_step_trace();
  EXPECT_EQ(first, (std::vector<std::string>{"/fast@1", "/fast@2", "/mid@2", "/fast@3", "/slow@3", "/fast@4",
                                             "/mid@4", "/fast@5", "/fast@6", "/mid@6", "/slow@6"}));
  for (int i = 0; i < 5; ++i) EXPECT_EQ(lock_step_trace(), first);
}

}  // namespace
