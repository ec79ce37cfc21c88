// Controller base class and registry: manifests, ports by name, parameters, life cycle, lock-step time.
#include "controllers/controller.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include <boost/asio/io_context.hpp>

#include "controllers/registry.h"
#include "tests/support/controller_fixture.h"

namespace {

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
  for (const char* t : {"Constant", "Counter", "Crash", "Deadline", "Gain", "Sum", "Threshold", "Timer"})
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
