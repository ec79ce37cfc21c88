#pragma once
// dca::Controller: the base of every controller (docs/packages.md).
//
// A controller type is a class derived from Controller (or PeriodicController, below) that opens with
// DCA_CONTROLLER(T), which declares
//   - `static Manifest Describe()`: its ports and parameters, each declared once as a constant (InSpec<T>,
//     OutSpec<T>, Param<T>) and listed by named fields; the registry gives it out without an instance
//     (`dca types`, `dca check`);
//   - a constructor `T(const ControllerContext&)` that binds the same constants: `in_(port(kIn))`,
//     `gain_(param(kGain))`. The name and the type come from the constant, so manifest and code cannot disagree;
// and its .cpp has DCA_REGISTER_CONTROLLER(T) (dca/registry.h). For example:
//   const dca::InSpec<double> kMeasured{.name = "Measured"};
//   const dca::OutSpec<double> kCommand{.name = "Command", .actuator = true};
//   const dca::Param<double> kKp{.name = "kp", .doc = "proportional gain", .min = 0};
//   dca::Manifest Pid::Describe() {
//     return {.type = "Pid", .doc = "a PID controller", .inputs = {kMeasured}, .outputs = {kCommand},
//             .params = {kKp, PeriodParam()}, .ends = dca::Ending::Never()};
//   }
//   Pid::Pid(const dca::ControllerContext& ctx)
//       : PeriodicController(ctx), measured_(port(kMeasured)), command_(port(kCommand)), kp_(param(kKp)) {}
//
// Life cycle. The node drives the public operations configure(), start() and halt(); they are final and do the
// safety duties themselves, then call the author's private hooks, which need no call to a base:
//   configure()  -> on_configure(): acquires and resets (again before every run).
//   start(init)  -> on_start(init): a run begins with an initial value; then the base starts the timer
//                   (PeriodicController) and the triggers (inputs declared `.trigger`).
//   (timer)      -> MainCalc(): THE HOT PATH, by the timer or a trigger while running: reads inputs, computes,
//                   writes outputs. It must not allocate, throw, take a lock, block, or call Lua.
//   halt()       -> the timer and triggers stop, on_halt() releases, then the base writes zero to every output
//                   declared `.actuator`: actuators are left safe whatever the hooks do.
// A run ends with Done(value) or Abort(reason): as halt(), then the event goes to the supervisor. Done/Abort when
// not running (after halt, or a second time) are ignored. The states and their transitions: State below.
//
// Parameters: the .dca arguments after the first (the host), as text, matched by position to the manifest's
// params. Every one is checked when the controller is made (its type, its range or allowed values): a missing one
// takes its default, a bad one is an error naming the controller and the parameter
// ("parameter 'tau' must be positive, got -0.005"): the constructor throws std::invalid_argument (the one place
// where an exception crosses the controller API: Registry::create passes it on).
//
// Live parameters: a parameter declared `.live = true` may change while the controller exists (docs/packages.md,
// "Live parameters"). The node calls set_parameter(name, text) on its loop thread, between two ticks (never during
// MainCalc): the base refuses a parameter that is unknown or not live, checks the text exactly as at construction
// (type, range, allowed values), stores it, then calls the private hook on_parameter(name), which reads
// `param(kX)` again into the members MainCalc uses and returns "" to accept, or a reason to refuse. On a refusal
// (or a throw) the base restores the old value: the controller keeps running with it. A type with a live
// parameter overrides on_parameter(); the base's refuses every change ("no on_parameter()"). For example:
//   const dca::Param<double> kKp{.name = "kp", .doc = "proportional gain", .min = 0, .live = true};
//   std::string Pid::on_parameter(std::string_view name) {
//     if (name == kKp.name) kp_ = param(kKp);
//     return "";
//   }
#include <charconv>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <msgpack.hpp>

#include <dca/component.h>
#include <dca/port.h>

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

/// A parameter as the manifest lists it (what `dca types` and `core.types()` show). Written by Param<T>.
struct ParamSpec {
  std::string name;
  std::string type = "number";  ///< "number", "integer" or "string"
  std::string default_value = {};  ///< used when the argument is absent; ignored when `required`
  bool required = false;
  bool variadic = false;  ///< the last parameter only: takes all remaining arguments
  std::string doc = {};
  std::optional<double> min = {};    ///< numbers: the least value allowed
  std::optional<double> max = {};    ///< numbers: the greatest value allowed
  std::optional<double> above = {};  ///< numbers: values must be greater than this (0: positive)
  std::vector<std::string> allowed = {};  ///< text: the values allowed (empty: any)
  bool live = false;  ///< may change while it runs (set_parameter; the type's on_parameter() takes it)
};

/// A number as a parameter's default is written: the shortest text that reads back the same.
inline std::string format_number(double v) {
  char b[32];
  const auto r = std::to_chars(b, b + sizeof b, v);
  return std::string(b, r.ptr);
}

/// A parameter's declaration: listed in the manifest, read in the constructor with param(). T is double
/// ("number"), std::int64_t ("integer"), std::string ("string") or std::vector<double> (a number parameter taking
/// all remaining arguments: the last one only).
template <class T>
struct Param {
  std::string name;
  std::string doc = {};
  std::optional<T> def = {};         ///< the value when the argument is absent; none: the argument is required
  std::optional<double> min = {};    ///< numbers: the least value allowed
  std::optional<double> max = {};    ///< numbers: the greatest value allowed
  std::optional<double> above = {};  ///< numbers: values must be greater than this (0: positive)
  std::vector<std::string> allowed = {};  ///< text: the values allowed (empty: any)
  bool live = false;  ///< may change while it runs: set_parameter(), then the type's on_parameter() (above)

  operator ParamSpec() const {  // NOLINT(google-explicit-constructor): a manifest lists specs
    ParamSpec s{.name = name, .doc = doc, .min = min, .max = max, .above = above, .allowed = allowed, .live = live};
    if constexpr (std::is_same_v<T, std::string>) s.type = "string";
    if constexpr (std::is_same_v<T, std::int64_t>) s.type = "integer";
    if constexpr (std::is_same_v<T, std::vector<double>>) s.variadic = true;
    else s.required = !def.has_value();
    if constexpr (std::is_same_v<T, double>) s.default_value = def ? format_number(*def) : "";
    if constexpr (std::is_same_v<T, std::int64_t>) s.default_value = def ? std::to_string(*def) : "";
    if constexpr (std::is_same_v<T, std::string>) s.default_value = def.value_or("");
    return s;
  }
};

/// How a run of a type can end by itself, for `dca check --verify` (a crash or a lost host can end any run,
/// whatever this says). A type that declares nothing is taken as able to end DONE or ABORTED at any time.
struct Ending {
  enum class Kind : std::uint8_t { Unspecified, Never, Done, Aborted, DoneOrAborted };
  Kind kind = Kind::Unspecified;
  std::string after = {};  ///< the number parameter holding the seconds after which it ends (Timer), or ""
  std::string never_when = {};  ///< a parameter that, at never_value, makes a run never end by itself, or ""
  std::string never_value = {};  ///< that parameter's value, as written in a file ("0")

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
  /// The same, but a run never ends by itself when parameter `param` is `value`: `Ending::Done().NeverWhen("limit",
  /// "0")` (a Counter whose limit is 0 counts for ever). `dca check --verify` reads the leaf's argument.
  [[nodiscard]] Ending NeverWhen(std::string param, std::string value) const {
    Ending e = *this;
    e.never_when = std::move(param);
    e.never_value = std::move(value);
    return e;
  }
};

/// "never", "done", "aborted", "done or aborted", or "" when unspecified.
std::string_view to_string(Ending::Kind k);

/// A controller type's manifest: what `dca types` and `core.types()` show. Written with named fields:
/// `{.type = "Pid", .doc = "...", .inputs = {kIn}, .outputs = {kOut}, .params = {kGain}, .ends = ...}`.
struct Manifest {
  std::string type;       ///< the type name in .dca files, e.g. "Gain"
  std::string doc = {};   ///< one line
  std::vector<PortSpec> inputs = {};
  std::vector<PortSpec> outputs = {};
  std::vector<ParamSpec> params = {};
  Ending ends = {};  ///< how a run ends by itself
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
  /// Where a controller is in its life cycle. Every change of state is one of the transitions listed here
  /// (legal()); an operation that would make another is refused (start() when Running) or does nothing (halt()
  /// when not Ready or Running).
  enum class State : std::uint8_t {
    Idle,      ///< made, nothing acquired yet.                       -> Ready (configure)
    Ready,     ///< on_configure() ran: ready to start.               -> Ready (configure), Running (start),
               ///<                                                      Stopped (halt)
    Running,   ///< on_start() ran; the timer and triggers run MainCalc. -> Finished (Done/Abort), Stopped (halt)
    Finished,  ///< ended by itself (Done/Abort), released.           -> Ready (configure, or start)
    Stopped,   ///< halted from outside, released.                    -> Ready (configure, or start)
  };
  /// Whether `from` -> `to` is one of the transitions listed in State.
  static bool legal(State from, State to);
  /// "idle", "ready", "running", "finished" or "stopped".
  static std::string_view to_string(State s);

  ~Controller() override;
  Controller(const Controller&) = delete;
  Controller& operator=(const Controller&) = delete;

  const std::string& name() const final { return ctx_.name; }
  /// The type name.
  const std::string& type() const { return manifest_.type; }
  /// The host argument.
  const std::string& host() const { return ctx_.host; }
  PortSet& ports() final { return *ports_; }
  /// Ready: on_configure() (after halt() when running). False, with the reason in *error, if it threw.
  bool configure(std::string* error) final;
  /// Running: configure() first unless Ready, on_start(init), then the timer and the triggers. False, with the
  /// reason in *error, if it is already running or a hook threw.
  bool start(Bytes init, std::string* error) final;
  /// Stopped, when Ready or Running: the timer and triggers stop, on_halt(), then every actuator output is
  /// written zero. Idempotent.
  void halt() final;
  /// The current state.
  State state() const { return state_; }
  /// MainCalc calls skipped because one was already running (an in-process cycle); the sample stays queued.
  std::uint64_t reentries() const { return reentries_; }
  /// MainCalc calls so far.
  std::uint64_t ticks() const { return ticks_; }
  /// Changes the live parameter `name` to `text` (as a .dca argument is written), between two ticks: refused
  /// when it is unknown, not declared `.live`, not a value of it (the constructor's checks) or when on_parameter()
  /// refuses or throws; then false, the old value kept, with "<Type> <path>: <why>" in *error.
  bool set_parameter(std::string_view name, const std::string& text, std::string* error) final;

 protected:
  /// Creates the ports listed in ctx.manifest and checks every parameter (type, range, allowed values). Throws
  /// std::invalid_argument naming the controller and the parameter, or when there is no manifest.
  explicit Controller(const ControllerContext& ctx);

  /// The input declared by `spec` (listed in the manifest's inputs).
  template <class T>
  In<T> port(const InSpec<T>& spec) {
    return In<T>(input(spec.name, PortTraits<T>::type, PortTraits<T>::size));
  }
  /// The output declared by `spec` (listed in the manifest's outputs).
  template <class T>
  Out<T> port(const OutSpec<T>& spec) {
    return Out<T>(output(spec.name, PortTraits<T>::type, PortTraits<T>::size));
  }

  /// The value of a parameter of the manifest (checked when the controller was made).
  double param(const Param<double>& p) const { return number(p.name); }
  std::int64_t param(const Param<std::int64_t>& p) const { return integer(p.name); }
  std::string param(const Param<std::string>& p) const { return text(p.name); }
  std::vector<double> param(const Param<std::vector<double>>& p) const { return numbers(p.name); }
  /// A parameter's text, as given in the .dca file (or its default): for messages.
  template <class T>
  std::string text(const Param<T>& p) const {
    return text(p.name);
  }
  /// std::invalid_argument("<Type> <name>: <what>"), for a constructor's own checks of its parameters.
  std::invalid_argument bad_param(const std::string& what) const;

  /// Calls MainCalc every `seconds` from now while running. Replaces any previous timer of this controller.
  void StartPeriodic(double seconds);
  /// Calls MainCalc once, `seconds` from now (while still running).
  void StartOneShot(double seconds);
  /// Cancels the timer.
  void StopTimer();

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
  /// When the current run started (its start()).
  Nanos started() const { return started_; }

 private:
  /// Acquires and resets; called by configure(), so before every run. May throw (the run does not start).
  virtual void on_configure() {}
  /// A run starts; `init` is the initial value (nil outside a value binding). May throw. The timer and the
  /// triggers start after it, by themselves.
  virtual void on_start(const msgpack::object& init) { (void)init; }
  /// The hot path (see the header comment): no allocation, no exceptions, no locks, no Lua.
  virtual void MainCalc() {}
  /// Releases. The actuators are written zero after it, by the base.
  virtual void on_halt() {}
  /// The live parameter `name` has a new value (set_parameter checked and stored it): read it again with
  /// param(), between two ticks. "" accepts; a reason (or a throw) refuses, and the base restores the old value.
  /// The base's refuses: a type with a live parameter overrides it.
  virtual std::string on_parameter(std::string_view name);

  friend class PeriodicController;
  friend struct ControllerAccess;  // the node's side and the tests (controllers/controller_access.h)

  Input& input(std::string_view name, PortType type, std::uint32_t size);
  Output& output(std::string_view name, PortType type, std::uint32_t size);
  double number(std::string_view name) const;
  std::int64_t integer(std::string_view name) const;
  std::string text(std::string_view name) const;
  std::vector<double> numbers(std::string_view name) const;
  void check_params() const;
  std::string change_param(std::size_t i, const std::string& text);
  void tick();
  void arm();
  void release();
  void finish(ComponentEvent e);
  bool fail(std::string* error, const std::string& what) const;

  ControllerContext ctx_;
  Manifest manifest_;
  std::unique_ptr<PortSet> ports_;
  State state_ = State::Idle;
  std::uint64_t timer_ = 0;       // TimerServer::Id
  double period_ = -1;            // PeriodicController: seconds between ticks (0: event-driven); < 0: none
  Nanos started_ = 0;
  std::vector<Input*> triggers_;  // the inputs declared `.trigger`
  std::vector<Input*> armed_;     // the triggers armed for this run
  std::vector<Output*> actuators_;
  bool in_main_calc_ = false;
  std::uint64_t reentries_ = 0, ticks_ = 0;
  std::string broken_;  // why it cannot run (a stand-in for a controller whose constructor threw), or ""
};

/// A controller whose MainCalc runs every `period` seconds while running: its manifest has the number
/// parameter "period" (PeriodParam), and start() starts the timer. In the event-driven variant a period of 0 is
/// allowed and means: MainCalc on each sample arriving at a `.trigger` input, or once at start when there is
/// none.
class PeriodicController : public Controller {
 public:
  /// Whether `period` 0 is allowed (the built-ins' event-driven convention).
  enum class Period : std::uint8_t { Positive, ZeroIsEventDriven };
  /// The parameter "period" (required when `def` is empty), positive or, event-driven, at least 0.
  static Param<double> PeriodParam(std::optional<double> def = 0.01, std::string doc = "seconds between ticks",
                                   Period mode = Period::Positive);

 protected:
  explicit PeriodicController(const ControllerContext& ctx, Period mode = Period::Positive);

  /// Seconds between ticks (0: event-driven).
  double period() const { return period_; }
};

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
