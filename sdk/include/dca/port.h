#pragma once
// Ports as a controller sees them (docs/packages.md): what a port carries (PortSpec), how a controller declares
// one (InSpec<T>, OutSpec<T>: the name once, the type from T) and its handles on them (In<T>, Out<T>).
//
//   T                             port type     size
//   double                        scalar        1
//   Eigen::Matrix<double, N, 1>   vector[N]     N
//   Eigen::VectorXd               vectorx       any
//   dca::PortValue                value         a msgpack value
//   a dca::msgs type (dca/msgs.h)  message       one ROS 2 message (its CDR), e.g. geometry_msgs/msg/Twist
//
// In<T>::read(x) takes the newest sample in one call and says what it found (OROCOS's FlowStatus): Read::New (a
// sample arrived since the last read: x is it), Read::Old (nothing new: x is the last sample again) or Read::None
// (never a sample: x untouched). The node's side of a port (queues, connections, transports) is host/port.h:
// nothing of it is in this header, so a change to the transports changes no package's ABI.
//
// Threading: one thread (the node's loop). read() and write() of scalar, fixed-size and message ports do not
// allocate. A message port's samples are the message's CDR (dca/msgs_cdr.h): In<M>::read decodes it, Out<M>::write
// encodes it; a port of one message type connects to a port of the same type only (docs/data-plane.md).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>

#include <Eigen/Core>
#include <msgpack.hpp>

#include "dca/msgs.h"
#include "dca/msgs_cdr.h"

namespace dca {

/// What a port carries.
enum class PortType : std::uint8_t {
  Scalar,   ///< one double
  Vector,   ///< a fixed number of doubles (Eigen::Matrix<double, N, 1>), N = PortSpec::size
  VectorX,  ///< any number of doubles (Eigen::VectorXd); PortSpec::size is 0
  Value,    ///< a msgpack value (any shape); PortSpec::size is 0
  Message,  ///< a ROS 2 message (dca/msgs.h) as CDR, named by PortSpec::message; PortSpec::size is 0
};

/// "scalar", "vector", "vectorx", "value" or "message".
std::string_view to_string(PortType t);
/// The PortType named `s`, or nothing.
std::optional<PortType> port_type_from(std::string_view s);

/// A port's declaration: name, type, size and units (what `dca types` lists).
struct PortSpec {
  std::string name;   ///< unique among the inputs (or outputs) of one component
  PortType type = PortType::Scalar;
  std::uint32_t size = 1;  ///< number of doubles: 1 for Scalar, N for Vector, 0 for VectorX and Value
  std::string units = {};  ///< free text, e.g. "m/s", "N", "" when dimensionless
  /// A device port: the robot signal it is wired to ("arm.q", "base.cmd_vel"; see sim/world.h), or "".
  /// The supervisor that owns the controller connects it to that signal of the robot process ("world"),
  /// always active; .dca files never name device ports.
  std::string device = {};
  bool trigger = false;   ///< an input whose samples run MainCalc (a plain or event-driven controller)
  bool actuator = false;  ///< an output that halt() writes zero to (all of its elements): left safe
  /// A Message port's ROS 2 type ("geometry_msgs/msg/Twist", a dca::msgs type's ros_name); "" for the others.
  std::string message = {};
};

/// A scalar port spec.
PortSpec scalar_port(std::string name, std::string units = "");
/// A fixed-size vector port spec.
PortSpec vector_port(std::string name, std::uint32_t size, std::string units = "");
/// A dynamic-size vector port spec.
PortSpec vectorx_port(std::string name, std::string units = "");
/// A msgpack value port spec.
PortSpec value_port(std::string name, std::string units = "");
/// A message port spec: `message` is a dca::msgs type's ros_name.
PortSpec message_port(std::string name, std::string message, std::string units = "");
/// A port's type as errors name it: "scalar", "vector[6]", "vectorx", "value", or a Message port's ROS 2 type
/// ("message" when it names none).
std::string describe_type(const PortSpec& s);

/// A sample's bytes: doubles in host byte order for numeric ports, msgpack bytes for Value ports, the message's
/// CDR (dca/msgs_cdr.h) for Message ports.
using Bytes = std::span<const std::byte>;

/// A msgpack value read from a Value port.
using PortValue = msgpack::object_handle;

/// What In<T>::read found (OROCOS's FlowStatus: NoData, OldData, NewData).
enum class Read : std::uint8_t {
  None,  ///< no sample ever: the target is untouched
  Old,   ///< no sample since the last read: the target is the last sample again
  New,   ///< a sample arrived since the last read: the target is the newest
};

class Input;    // the node's input (host/port.h): opaque here
class Output;   // the node's output (host/port.h): opaque here
class PortSet;  // a component's ports (host/port.h): opaque here

/// The port operations dca provides (resolved in the dca process that loads a package).
namespace port_detail {
Read read(Input& in, double& x);
Read read(Input& in, double* x, std::size_t n);  ///< a fixed-size sample of n doubles
Read read(Input& in, Eigen::VectorXd& x);
Read read(Input& in, PortValue& x);
bool pop(Input& in, double& x);
bool write(Output& out, double v);
bool write(Output& out, const double* v, std::size_t n);
bool write_bytes(Output& out, const char* data, std::size_t n);
Read read_bytes(Input& in, Bytes& x);  ///< the newest sample's bytes, valid until the input's next delivery
}  // namespace port_detail

/// How a C++ type travels on a port (the table in the header comment).
template <class T>
struct PortTraits;
template <>
struct PortTraits<double> {
  static constexpr PortType type = PortType::Scalar;
  static constexpr std::uint32_t size = 1;
};
template <int N>
struct PortTraits<Eigen::Matrix<double, N, 1>> {
  static_assert(N > 0, "a fixed-size port has at least one element; use Eigen::VectorXd for any size");
  static constexpr PortType type = PortType::Vector;
  static constexpr std::uint32_t size = N;
};
template <>
struct PortTraits<Eigen::VectorXd> {
  static constexpr PortType type = PortType::VectorX;
  static constexpr std::uint32_t size = 0;
};
template <>
struct PortTraits<PortValue> {
  static constexpr PortType type = PortType::Value;
  static constexpr std::uint32_t size = 0;
};
template <msgs::Message M>
struct PortTraits<M> {
  static constexpr PortType type = PortType::Message;
  static constexpr std::uint32_t size = 0;
  static constexpr std::string_view message = M::ros_name;
};

/// The ROS 2 type a port of T carries ("" but for messages).
template <class T>
std::string port_message() {
  if constexpr (PortTraits<T>::type == PortType::Message) return std::string(PortTraits<T>::message);
  else return {};
}

/// An input's declaration, listed in the manifest and bound in the constructor: port(kIn) gives its In<T>.
template <class T>
struct InSpec {
  std::string name;
  std::string units = {};
  std::string device = {};  ///< a device port: the robot signal it is wired to
  bool trigger = false;     ///< its samples run MainCalc (a plain or event-driven controller)
  operator PortSpec() const {  // NOLINT(google-explicit-constructor): a manifest lists specs
    return {name, PortTraits<T>::type, PortTraits<T>::size, units, device, trigger, false, port_message<T>()};
  }
};

/// An output's declaration, listed in the manifest and bound in the constructor: port(kOut) gives its Out<T>.
template <class T>
struct OutSpec {
  std::string name;
  std::string units = {};
  std::string device = {};  ///< a device port: the robot signal it is wired to
  bool actuator = false;    ///< halt() writes zero to it after on_halt(): left safe whatever the hooks do
  operator PortSpec() const {  // NOLINT(google-explicit-constructor): a manifest lists specs
    return {name, PortTraits<T>::type, PortTraits<T>::size, units, device, false, actuator, port_message<T>()};
  }
};

/// `spec` as a device port wired to the robot signal `signal`.
template <class Spec>
Spec device(Spec spec, std::string signal) {
  spec.device = std::move(signal);
  return spec;
}
/// `spec` as an actuator: halt() writes it zero.
template <class T>
OutSpec<T> actuator(OutSpec<T> spec) {
  spec.actuator = true;
  return spec;
}
/// `spec` as a trigger: its samples run MainCalc.
template <class T>
InSpec<T> trigger(InSpec<T> spec) {
  spec.trigger = true;
  return spec;
}

class Controller;

/// A controller's handle on one of its inputs (Controller::port(InSpec<T>)). Copyable; valid as long as its
/// controller.
template <class T>
class In {
 public:
  /// Takes the newest sample into `x` (see Read). Real-time safe for scalar, fixed-size and message ports.
  Read read(T& x) {
    if constexpr (PortTraits<T>::type == PortType::Vector) {
      return port_detail::read(*in_, x.data(), x.size());
    } else if constexpr (PortTraits<T>::type == PortType::Message) {
      Bytes b;
      const Read r = port_detail::read_bytes(*in_, b);
      if (r == Read::None || !msgs::cdr_decode(b, x)) return Read::None;  // the node checked it: never refused
      return r;
    } else {
      return port_detail::read(*in_, x);
    }
  }
  /// Takes the oldest queued sample into `x`: false when none is queued. Scalar ports only.
  bool pop(T& x) {
    static_assert(std::is_same_v<T, double>, "pop() is for scalar inputs");
    return port_detail::pop(*in_, x);
  }

 private:
  friend class Controller;
  explicit In(Input& in) : in_(&in) {}
  Input* in_;
};

/// A controller's handle on one of its outputs (Controller::port(OutSpec<T>)). Copyable; valid as long as its
/// controller.
template <class T>
class Out {
 public:
  /// Writes a sample to every connection. False (counted by the node) when its size does not fit the port.
  /// Real-time safe for scalar and fixed-size ports.
  bool write(double v)
    requires(PortTraits<T>::type == PortType::Scalar)
  {
    return port_detail::write(*out_, v);
  }
  bool write(const Eigen::Ref<const Eigen::VectorXd>& v)
    requires(PortTraits<T>::type == PortType::Vector || PortTraits<T>::type == PortType::VectorX)
  {
    return port_detail::write(*out_, v.data(), static_cast<std::size_t>(v.size()));
  }
  /// Writes a message as its CDR (no allocation: encoded on the stack). False when the node refuses it.
  bool write(const T& m)
    requires(PortTraits<T>::type == PortType::Message)
  {
    std::array<std::byte, msgs::cdr_max_size<T>> buf;
    const std::size_t n = msgs::cdr_encode(m, buf);
    return port_detail::write_bytes(*out_, reinterpret_cast<const char*>(buf.data()), n);
  }
  /// Writes any msgpack-packable value (allocates).
  template <class V>
  bool write(const V& v)
    requires(PortTraits<T>::type == PortType::Value)
  {
    msgpack::sbuffer sb;
    msgpack::pack(sb, v);
    return port_detail::write_bytes(*out_, sb.data(), sb.size());
  }

 private:
  friend class Controller;
  explicit Out(Output& out) : out_(&out) {}
  Output* out_;
};

}  // namespace dca
