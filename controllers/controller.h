#pragma once
// dca::Controller: the base of every controller module (ARCHITECTURE.md, "Controllers").
//
// A controller type is a class derived from Controller with
//   - a static `Manifest Describe()` listing its ports (name, type, size, units) and parameters: the registry
//     gives it out without an instance (`dca types`, `dca check`);
//   - a constructor `T(const ControllerContext&)` that declares its ports by name: `in_(input("Force"))`,
//     `out_(output("Velocity"))` (the types come from the manifest, so the two cannot disagree) and reads its
//     parameters (`number("gain")`); it may throw std::invalid_argument for a bad parameter;
//   - DCA_REGISTER_CONTROLLER(T) in its .cpp (controllers/registry.h).
//
// Life cycle (driven by the node on its supervisor's orders):
//   Init()      acquires and resets (called again after Stop()).
//   Run(init)   starts a run with an initial value; a periodic controller starts its timer here
//               (StartPeriodic), an event-driven one its input triggers (TriggerOn).
//   MainCalc()  THE HOT PATH, called by its timer or trigger while running: reads inputs, computes, writes
//               outputs. It must not allocate, throw, take a lock, block, or call Lua.
//   Stop()      releases, leaving actuators safe (zero velocity), so that Init() may be called again.
// A run ends with Done(value) or Abort(reason): the timer and triggers stop, Stop() is called, the event goes
// to the supervisor. Done/Abort when not running (after Stop, or a second time) are ignored.
//
// Parameters: the .dca arguments after the first (the host), as text, matched by position to the manifest's
// params; a missing one takes its default, a bad one is an error naming the controller and the parameter.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <msgpack.hpp>

#include "host/port.h"
#include "host/component.h"
#include "host/timers.h"

namespace dca {

/// A parameter's declaration.
struct ParamSpec {
  std::string name;
  std::string type;           ///< "number", "integer" or "string"
  std::string default_value;  ///< used when the argument is absent; ignored when `required`
  bool required = false;
  bool variadic = false;      ///< the last parameter only: takes all remaining arguments
  std::string doc;
};

/// A controller type's manifest: what `dca types` and `core.types()` show.
struct Manifest {
  std::string type;  ///< the type name in .dca files, e.g. "Gain"
  std::string doc;   ///< one line
  std::vector<PortSpec> inputs;
  std::vector<PortSpec> outputs;
  std::vector<ParamSpec> params;
};

/// What a controller is constructed with.
struct ControllerContext {
  std::string name;                 ///< instance PATH, e.g. "/door/hit"
  std::string host;                 ///< the first .dca argument
  std::vector<std::string> params;  ///< the other .dca arguments, as text
  TimerServer* timers = nullptr;    ///< the process's TimerServer (required to run)
  const Manifest* manifest = nullptr;  ///< set by Registry::create
};

/// The base class of every controller.
class Controller : public Component {
 public:
  /// Where a controller is in its life cycle.
  enum class State : std::uint8_t { Idle, Ready, Running, Finished, Stopped };

  ~Controller() override;
  Controller(const Controller&) = delete;
  Controller& operator=(const Controller&) = delete;

  const std::string& name() const override { return ctx_.name; }
  /// The type name.
  const std::string& type() const { return manifest_.type; }
  /// The host argument.
  const std::string& host() const { return ctx_.host; }
  PortSet& ports() override { return ports_; }
  std::string init() override;
  std::string run(Bytes init) override;
  void stop() override;
  /// The current state.
  State state() const { return state_; }
  /// MainCalc calls skipped because one was already running (an in-process cycle); the sample stays queued.
  std::uint64_t reentries() const { return reentries_; }
  /// MainCalc calls so far.
  std::uint64_t ticks() const { return ticks_; }

 protected:
  /// Creates the ports listed in ctx.manifest. Throws std::invalid_argument without a manifest.
  explicit Controller(const ControllerContext& ctx);

  /// Acquires and resets. May throw (reported to the supervisor as the init error).
  virtual void Init() {}
  /// Starts a run; `init` is the initial value (nil outside a value binding). May throw.
  virtual void Run(const msgpack::object& init) { (void)init; }
  /// The hot path (see the header comment): no allocation, no exceptions, no locks, no Lua.
  virtual void MainCalc() {}
  /// Releases; leaves actuators safe.
  virtual void Stop() {}

  /// The input named `name`. Throws std::invalid_argument listing the inputs when there is none.
  Input& input(std::string_view name);
  /// The output named `name`. Throws std::invalid_argument listing the outputs when there is none.
  Output& output(std::string_view name);

  /// The parameter `name` as a number (throws std::invalid_argument naming it when absent or not a number).
  double number(std::string_view name) const;
  /// The parameter `name` as an integer.
  std::int64_t integer(std::string_view name) const;
  /// The parameter `name` as text.
  std::string text(std::string_view name) const;
  /// A variadic parameter's values as numbers (possibly none).
  std::vector<double> numbers(std::string_view name) const;

  /// Calls MainCalc every `seconds` from now while running. Replaces any previous timer of this controller.
  void StartPeriodic(double seconds);
  /// Calls MainCalc once, `seconds` from now (while still running).
  void StartOneShot(double seconds);
  /// Cancels the timer.
  void StopTimer();
  /// Calls MainCalc after each sample that arrives at `in` while running.
  void TriggerOn(Input& in);

  /// Ends the run with DONE and no value (nil).
  void Done();
  /// Ends the run with DONE(v).
  void Done(double v);
  /// Ends the run with DONE(text).
  void Done(std::string_view v);
  /// Ends the run with DONE(v) for any msgpack-packable v.
  template <class T>
  void DoneWith(const T& v) {
    msgpack::sbuffer sb;
    msgpack::pack(sb, v);
    finish({ComponentEvent::Kind::Done, std::string(sb.data(), sb.size()), ""});
  }
  /// Ends the run with ABORTED(reason).
  void Abort(std::string reason);

  /// The process's TimerServer.
  TimerServer& timers() const;
  /// The clock's time (wall or simulated).
  Nanos now() const { return timers().now(); }

 private:
  void tick();
  void finish(ComponentEvent e);
  const ParamSpec* param(std::string_view name, std::size_t& index) const;
  std::string raw_param(std::string_view name, const ParamSpec*& spec) const;

  ControllerContext ctx_;
  Manifest manifest_;
  PortSet ports_;
  State state_ = State::Idle;
  TimerServer::Id timer_ = 0;
  std::vector<Input*> triggers_;
  bool in_main_calc_ = false;
  std::uint64_t reentries_ = 0, ticks_ = 0;
};

}  // namespace dca
