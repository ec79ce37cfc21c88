#pragma once
// What a node hosts: a component with named ports and a life cycle (configure / start / halt) that ends its runs
// with DONE(value) or ABORTED(reason). dca::Controller (dca/controller.h) is the one implementation; the node
// (host/node.h) knows only this interface, so host/ does not depend on controllers/.
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

#include <dca/port.h>

namespace dca {

/// The end of a run, reported to the supervisor as `done {value}` or `aborted {reason}`.
struct ComponentEvent {
  enum class Kind : std::uint8_t { Done, Aborted };
  Kind kind = Kind::Done;
  std::string value;   ///< Done: the value, msgpack-encoded (a packed nil when there is none)
  std::string reason;  ///< Aborted: why
};

/// A hosted component (a controller instance).
class Component {
 public:
  virtual ~Component() = default;
  /// The instance's name (its PATH, e.g. "/door/hit").
  virtual const std::string& name() const = 0;
  /// Its ports (host/port.h).
  virtual PortSet& ports() = 0;
  /// Acquires and resets. False, with the reason in *error (when not null), if it cannot.
  virtual bool configure(std::string* error) = 0;
  /// Starts a run with an initial value (msgpack bytes; empty for nil), configuring first if needed. False,
  /// with the reason in *error (when not null), if it cannot.
  virtual bool start(Bytes init, std::string* error) = 0;
  /// Stops the run (leaves actuators safe); a later DONE/ABORTED of this run is ignored. Idempotent.
  virtual void halt() = 0;
  /// Changes a parameter while it runs (`text` as a .dca argument is written), between two ticks: true, or false
  /// with the reason in *error (when not null). A component without live parameters refuses every one.
  virtual bool set_parameter(std::string_view name, const std::string& text, std::string* error) {
    (void)text;
    if (error) *error = this->name() + ": no parameter '" + std::string(name) + "' changes while it runs";
    return false;
  }
  /// Where DONE/ABORTED go (set by the node).
  std::function<void(const ComponentEvent&)> on_event;
};

}  // namespace dca
