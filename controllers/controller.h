#pragma once
// dca::Controller: the base of every controller module (docs/packages.md).
//
// A controller type is a class derived from Controller (or PeriodicController, below) that opens with
// DCA_CONTROLLER(T), which declares
//   - `static Manifest Describe()`, listing its ports (name, type, size, units) and parameters: the registry
//     gives it out without an instance (`dca types`, `dca check`);
//   - a constructor `T(const ControllerContext&)` that binds its ports by name: `in_(input("Force"))`,
//     `out_(output("Velocity"))` (the types come from the manifest, so the two cannot disagree) and reads its
//     parameters (`number("gain")`, `positive("period")`); it throws std::invalid_argument for a bad parameter
//     (the one place where an exception crosses the controller API: Registry::create passes it on);
// and its .cpp has DCA_REGISTER_CONTROLLER(T) (controllers/registry.h).
// For example (controllers/door/linear_trajectory.h, .cpp):
//   class LinearTrajectory final : public PeriodicController {
//     DCA_CONTROLLER(LinearTrajectory)
//     void MainCalc() override;
//     Output& vel_;              // vel_(actuator("Vel")) in the constructor: written zero by Stop()
//     double speed_, distance_;  // speed_(positive("speed")), ...
//   };
//
// Life cycle (driven by the node on its supervisor's orders, through the public operations configure(),
// start() and halt(), which call the hooks below; a hook never has to be told apart from them by case):
//   Init()      acquires and resets (called again after Stop(), so before every run).
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
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <msgpack.hpp>

#include "host/port.h"
#include "host/component.h"

namespace dca {

// From host/timers.h, declared again here so that a controller (and a controller package: the installed SDK)
// compiles without Asio.
class TimerServer;
/// Nanoseconds on a Clock (host/timers.h).
using Nanos = std::int64_t;
/// Seconds -> Nanos (host/timers.h).
Nanos from_seconds(double s);
/// Nanos -> seconds (host/timers.h).
double to_seconds(Nanos n);

/// A parameter's declaration.
struct ParamSpec {
  std::string name;
  std::string type;           ///< "number", "integer" or "string"
  std::string default_value;  ///< used when the argument is absent; ignored when `required`
  bool required = false;
  bool variadic = false;      ///< the last parameter only: takes all remaining arguments
  std::string doc;

  /// A parameter that must be given.
  static ParamSpec Required(std::string name, std::string type, std::string doc);
  /// A parameter with a default.
  static ParamSpec Optional(std::string name, std::string type, std::string def, std::string doc);
  /// An optional number parameter.
  static ParamSpec Number(std::string name, std::string def, std::string doc);
  /// The last parameter, taking all remaining arguments.
  static ParamSpec Variadic(std::string name, std::string type, std::string doc);
};

/// How a run of a type can end by itself, for `dca check --verify` (a crash or a lost host can end any run,
/// whatever this says). A type that declares nothing is taken as able to end DONE or ABORTED at any time.
struct Ending {
  enum class Kind : std::uint8_t { Unspecified, Never, Done, Aborted, DoneOrAborted };
  Kind kind = Kind::Unspecified;
  std::string after = {};  ///< the number parameter holding the seconds after which it ends (Timer), or ""

  /// Runs until it is stopped (a sensor, a drive).
  static Ending Never() { return {Kind::Never}; }
  /// Ends DONE only.
  static Ending Done() { return {Kind::Done}; }
  /// Ends ABORTED only.
  static Ending Aborted() { return {Kind::Aborted}; }
  /// Ends DONE or ABORTED.
  static Ending DoneOrAborted() { return {Kind::DoneOrAborted}; }
  /// Ends DONE `param` seconds after each start.
  static Ending DoneAfter(std::string param) { return {Kind::Done, std::move(param)}; }
  /// Ends ABORTED `param` seconds after each start.
  static Ending AbortedAfter(std::string param) { return {Kind::Aborted, std::move(param)}; }
};

/// "never", "done", "aborted", "done or aborted", or "" when unspecified.
std::string_view to_string(Ending::Kind k);

/// A controller type's manifest: what `dca types` and `core.types()` show.
struct Manifest {
  std::string type;  ///< the type name in .dca files, e.g. "Gain"
  std::string doc;   ///< one line
  std::vector<PortSpec> inputs;
  std::vector<PortSpec> outputs;
  std::vector<ParamSpec> params;
  Ending ends = {};  ///< how a run ends by itself (the last field, optional in a Describe())
  std::string package = {};  ///< the controller package that defines it ("" for a built-in); set by the registry
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
  /// Calls Init() (after halt() when running). False, with the reason in *error, if Init threw.
  bool configure(std::string* error) override;
  /// Starts a run: configure() first unless Ready, then Run(init). False, with the reason in *error, if it is
  /// already running or Init or Run threw.
  bool start(Bytes init, std::string* error) override;
  /// Calls Stop() when Ready or Running (the timer and triggers stop first). Idempotent.
  void halt() override;
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
  /// The parameter `name` as a number > 0 (throws std::invalid_argument naming it otherwise).
  double positive(std::string_view name) const;
  /// The parameter `name` as a number >= 0 (throws std::invalid_argument naming it otherwise).
  double non_negative(std::string_view name) const;
  /// std::invalid_argument("<Type> <name>: <what>"), for a constructor's own parameter checks.
  std::invalid_argument bad_param(const std::string& what) const;

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
  Nanos now() const;

 private:
  void tick();
  void finish(ComponentEvent e);
  const ParamSpec* param(std::string_view name, std::size_t& index) const;
  double checked(std::string_view name, bool ok_when_zero) const;
  bool fail(std::string* error, const std::string& what) const;
  std::string raw_param(std::string_view name, const ParamSpec*& spec) const;

  ControllerContext ctx_;
  Manifest manifest_;
  PortSet ports_;
  State state_ = State::Idle;
  std::uint64_t timer_ = 0;  // TimerServer::Id
  std::vector<Input*> triggers_;
  bool in_main_calc_ = false;
  std::uint64_t reentries_ = 0, ticks_ = 0;
};

/// A controller whose MainCalc runs every `period` seconds while running: its manifest has the number
/// parameter "period" (PeriodParam), which must be positive, and Run() starts the timer. In the event-driven
/// variant a period of 0 is allowed and means: MainCalc on each sample arriving at an input bound with
/// trigger(), or once at Run when there is none. Stop() writes zero to every output bound with actuator().
class PeriodicController : public Controller {
 public:
  /// Whether `period` 0 is allowed (the built-ins' event-driven convention).
  enum class Period : std::uint8_t { Positive, ZeroIsEventDriven };
  /// The parameter "period" with its default and doc.
  static ParamSpec PeriodParam(std::string def = "0.01", std::string doc = "seconds between ticks");

 protected:
  explicit PeriodicController(const ControllerContext& ctx, Period mode = Period::Positive);

  /// Starts the timer (or, event-driven, the triggers). A subclass that overrides it calls it last.
  void Run(const msgpack::object& init) override;
  /// Writes zero to the actuators.
  void Stop() override;

  /// The output named `name`, written zero (all of its elements) by Stop(): an actuator left safe.
  Output& actuator(std::string_view name);
  /// The input named `name`, which triggers MainCalc when event-driven.
  Input& trigger(std::string_view name);
  /// Seconds between ticks (0: event-driven).
  double period() const { return period_; }
  /// When the current run started (its Run).
  Nanos started() const { return started_; }

 private:
  double period_;
  Nanos started_ = 0;
  std::vector<Output*> actuators_;
  std::vector<Input*> triggers_;
};

/// Reads the newest sample of `in` into `v` when one arrived since the last call. Returns whether one did.
template <int N>
bool fresh(Input& in, Eigen::Matrix<double, N, 1>& v) {
  if (!in.take_latest()) return false;
  const auto s = in.vector();
  if (s.size() != N) return false;
  v = s;
  return true;
}

}  // namespace dca

/// Opens a controller class T: declares its manifest `static Manifest Describe()` and its constructor
/// `explicit T(const ControllerContext&)` (both defined in its .cpp), public; what follows is private
/// (the hooks, which the base class calls, and the state).
#define DCA_CONTROLLER(T)                          \
 public:                                           \
  static ::dca::Manifest Describe();               \
  explicit T(const ::dca::ControllerContext& ctx); \
                                                   \
 private:
