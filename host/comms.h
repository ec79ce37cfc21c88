#pragma once
// The data plane: named, typed ports and the connections between them (ARCHITECTURE.md, "Two planes").
//
// A port carries samples of one type: a scalar (double), a fixed-size vector of doubles (Eigen), a
// dynamic-size vector of doubles (Eigen), or a msgpack value. An output feeds any number of inputs and an
// input is fed by any number of outputs. A connection goes output -> input:
//   - in the same process: a direct hand-off (the sample is copied into the input's queue, no socket);
//   - on the same host: over a Unix stream socket;
//   - across hosts: over TCP with TCP_NODELAY.
// Endpoint::connect picks the transport from where the two ends live (choose_transport).
//
// Push connections deliver every sample into the input's bounded queue. Overflow policy: DROP-OLDEST — when
// the queue is full the oldest queued sample is discarded, counted in Input::dropped() and reported in the
// port statistics (and once in the log of the process). Pull connections deliver nothing on their own: the
// reader asks (Input::request()) and the source answers with its latest sample.
//
// Every connection belongs to a connection set (a name chosen by the supervisor) and is created inactive.
// Activating or deactivating a set flips one flag: no socket is opened or closed. An inactive connection sends
// nothing (its samples are skipped and counted). A broken connection (peer closed, reset) is reported to the
// endpoint's event callback on both sides; it never blocks a writer.
//
// Threading: everything here runs on the process's one io_context thread; nothing takes a lock. The hot-path
// calls (Output::write*, Input::pop/scalar/vector) do not allocate for scalar and fixed-size ports once the
// connection is made (dynamic vectors allocate only when a sample is bigger than any before; values allocate).
//
// Data frames on sockets: a 4-byte big-endian length, a 1-byte kind, then the body (comms_internal.h).
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <boost/asio/io_context.hpp>
#include <msgpack.hpp>

namespace dca {

/// What a port carries.
enum class PortType : std::uint8_t {
  Scalar,   ///< one double
  Vector,   ///< a fixed number of doubles (Eigen::Matrix<double, N, 1>), N = PortSpec::size
  VectorX,  ///< any number of doubles (Eigen::VectorXd); PortSpec::size is 0
  Value,    ///< a msgpack value (any shape); PortSpec::size is 0
};

/// "scalar", "vector", "vectorx" or "value".
std::string_view to_string(PortType t);
/// The PortType named `s`, or nothing.
std::optional<PortType> port_type_from(std::string_view s);

/// A port's declaration: name, type, size and units (what `dca types` lists).
struct PortSpec {
  std::string name;   ///< unique among the inputs (or outputs) of one component
  PortType type = PortType::Scalar;
  std::uint32_t size = 1;  ///< number of doubles: 1 for Scalar, N for Vector, 0 for VectorX and Value
  std::string units;  ///< free text, e.g. "m/s", "N", "" when dimensionless
  /// A device port: the robot signal it is wired to ("arm.q", "base.cmd_vel"; see sim/world.h), or "".
  /// The supervisor that owns the controller connects it to that signal of the robot process ("world"),
  /// always active; .dca files never name device ports.
  std::string device;
};

/// A scalar port spec.
PortSpec scalar_port(std::string name, std::string units = "");
/// A fixed-size vector port spec.
PortSpec vector_port(std::string name, std::uint32_t size, std::string units = "");
/// A dynamic-size vector port spec.
PortSpec vectorx_port(std::string name, std::string units = "");
/// A msgpack value port spec.
PortSpec value_port(std::string name, std::string units = "");

/// Why two ports cannot be connected ("" when they can): type or size differ.
std::string compatibility_error(const PortSpec& out, const PortSpec& in);

/// Push: every sample goes into the input's queue. Pull: the reader asks for the latest sample.
enum class Mode : std::uint8_t { Push, Pull };
/// "push" or "pull".
std::string_view to_string(Mode m);
/// The Mode named `s`, or nothing.
std::optional<Mode> mode_from(std::string_view s);

/// How a connection travels.
enum class Transport : std::uint8_t { InProcess, Unix, Tcp };
/// "inprocess", "unix" or "tcp".
std::string_view to_string(Transport t);

/// A port's counters (reported by the node's `ports {}` reply).
struct PortStats {
  std::uint64_t samples = 0;   ///< samples written (output) or received (input)
  std::uint64_t dropped = 0;   ///< input: queued samples dropped by the drop-oldest policy
  std::uint64_t rejected = 0;  ///< samples of the wrong size or malformed, refused and counted
  std::uint64_t skipped = 0;   ///< output: samples not sent because the connection's set was inactive
};

/// A sample's bytes: doubles in host byte order for numeric ports, msgpack bytes for Value ports.
using Bytes = std::span<const std::byte>;

class Input;
class Output;
class Endpoint;

/// Common to inputs and outputs: the spec, the latest sample and counters.
class Port {
 public:
  virtual ~Port() = default;
  Port(const Port&) = delete;
  Port& operator=(const Port&) = delete;
  /// The declaration.
  const PortSpec& spec() const { return spec_; }
  /// The port's name.
  const std::string& name() const { return spec_.name; }
  /// True once a sample has been written or received.
  bool has_latest() const { return has_latest_; }
  /// The most recent sample's bytes (empty before the first).
  Bytes latest_bytes() const { return {latest_.data(), latest_size_}; }
  /// Counters.
  const PortStats& stats() const { return stats_; }
  /// Packs the latest sample as msgpack: nil before any, a number (scalar), an array of numbers (vectors), or
  /// the value itself.
  void pack_latest(msgpack::packer<msgpack::sbuffer>& pk) const;

 protected:
  explicit Port(PortSpec spec);
  /// Copies `b` into the latest-sample buffer (allocates only when `b` is bigger than ever before).
  void set_latest(Bytes b);
  /// Checks a sample's size against the spec; counts a rejection when it does not fit.
  bool accepts(Bytes b);

  PortSpec spec_;
  std::vector<std::byte> latest_;
  std::size_t latest_size_ = 0;
  bool has_latest_ = false;
  PortStats stats_;
};

/// A connection feeding an input: told when the input goes away first.
class InputFeeder {
 public:
  virtual ~InputFeeder() = default;
  /// The input is being destroyed: forget it.
  virtual void input_gone() = 0;
};

/// Something that answers a pull request for an input (one per pull connection feeding it).
class PullSource {
 public:
  virtual ~PullSource() = default;
  /// Asks for the source's latest sample; it arrives later (or at once in-process) through Input::deliver.
  virtual void request() = 0;
};

/// An input port: a bounded queue of pushed samples (drop-oldest) and the current sample that readers see.
class Input final : public Port {
 public:
  /// An input with room for `queue` pushed samples (at least 1); each push connection grows it to its own
  /// `queue` (ConnectRequest::queue), so the capacity is the largest asked for.
  explicit Input(PortSpec spec, std::size_t queue = 1);
  ~Input() override;

  /// Takes the oldest queued sample and makes it current. False when the queue is empty. Real-time safe.
  bool pop();
  /// Drains the queue, making the newest queued sample current. False when nothing was queued. Real-time safe.
  bool take_latest();
  /// Number of samples waiting in the queue.
  std::size_t queued() const { return count_; }
  /// The queue's capacity.
  std::size_t capacity() const { return slots_.size(); }
  /// Grows the queue to hold `n` samples (never shrinks; not real-time).
  void reserve_queue(std::size_t n);
  /// Asks every pull connection feeding this input for its latest sample (real-time safe: no wait).
  void request();
  /// True once a current sample exists (after pop/take_latest, or a pull answer).
  bool has_current() const { return current_size_ > 0 || has_current_; }

  /// The current sample as a scalar (0 before any).
  double scalar() const;
  /// The current sample as a vector (empty before any).
  Eigen::Map<const Eigen::VectorXd> vector() const;
  /// The current sample's bytes.
  Bytes current_bytes() const { return {current_.data(), current_size_}; }
  /// The current sample as a msgpack value (nil before any; allocates: not for MainCalc of hard real-time code).
  msgpack::object_handle value() const;

  /// Called by connections: a pushed sample. Queued (drop-oldest when full), then on_sample runs.
  void deliver(Bytes b);
  /// Called by connections: a pull answer. Becomes the current sample directly, then on_sample runs.
  void deliver_pulled(Bytes b);
  /// Runs after each delivered sample (a controller triggered by its input sets this).
  std::function<void()> on_sample;
  /// Runs on the first sample dropped by the drop-oldest policy (Endpoint reports it as an Overflow event).
  std::function<void()> on_overflow;

  /// Adds or removes a pull connection feeding this input (done by Endpoint).
  void add_pull_source(PullSource* s);
  void remove_pull_source(PullSource* s);
  /// Adds or removes a connection that holds this input (told when the input is destroyed).
  void add_feeder(InputFeeder* f);
  void remove_feeder(InputFeeder* f);

 private:
  void make_current(const std::vector<std::byte>& b, std::size_t n);
  std::vector<std::vector<std::byte>> slots_;
  std::vector<std::size_t> sizes_;
  std::size_t head_ = 0, count_ = 0;
  std::vector<std::byte> current_;
  std::size_t current_size_ = 0;
  bool has_current_ = false;
  std::vector<PullSource*> pull_sources_;
  std::vector<InputFeeder*> feeders_;
  bool warned_drop_ = false;
};

/// A connection's sending side, attached to an output (internal: see comms.cpp).
class Link;

/// An output port: write() stores the latest sample and hands it to every active push connection.
class Output final : public Port {
 public:
  explicit Output(PortSpec spec);
  ~Output() override;

  /// Writes a scalar. Real-time safe. False (and counted) if the port is not a scalar.
  bool write(double v);
  /// Writes a vector. Real-time safe for fixed-size ports. False (and counted) if the size is wrong.
  bool write(const Eigen::Ref<const Eigen::VectorXd>& v);
  /// Writes a msgpack value (Value ports; allocates).
  template <class T>
  bool write_value(const T& v) {
    scratch_.clear();
    msgpack::pack(scratch_, v);
    return write_bytes({reinterpret_cast<const std::byte*>(scratch_.data()), scratch_.size()});
  }
  /// Writes raw sample bytes (already in the port's encoding).
  bool write_bytes(Bytes b);

  /// Connections attached (done by Endpoint).
  void attach(Link* l);
  void detach(Link* l);
  /// Number of connections from this output.
  std::size_t links() const { return links_.size(); }

 private:
  std::vector<Link*> links_;
  msgpack::sbuffer scratch_;
};

/// The named ports of one component (a controller instance): what a connection names with (PATH, port).
class PortSet {
 public:
  /// Declares an input. Throws std::invalid_argument when the name is taken.
  Input& add_input(PortSpec spec, std::size_t queue = 1);
  /// Declares an output. Throws std::invalid_argument when the name is taken.
  Output& add_output(PortSpec spec);
  /// The input named `name`, or nullptr.
  Input* find_input(std::string_view name) const;
  /// The output named `name`, or nullptr.
  Output* find_output(std::string_view name) const;
  /// All inputs, in declaration order.
  const std::vector<std::unique_ptr<Input>>& inputs() const { return inputs_; }
  /// All outputs, in declaration order.
  const std::vector<std::unique_ptr<Output>>& outputs() const { return outputs_; }
  /// "no input 'In2' on compliant; inputs are: In1, Force" (or "...has no inputs").
  std::string no_such_input(std::string_view component, std::string_view name) const;
  /// The same for outputs.
  std::string no_such_output(std::string_view component, std::string_view name) const;

 private:
  std::vector<std::unique_ptr<Input>> inputs_;
  std::vector<std::unique_ptr<Output>> outputs_;
};

/// Where a destination component lives (from the NameServer's endpoints record).
struct Location {
  std::string host;      ///< logical host name
  std::string data_uds;  ///< its node's Unix-socket data endpoint (path)
  std::string data_tcp;  ///< its node's TCP data endpoint ("127.0.0.1:port")
};

/// In-process when `dest_local`, else Unix socket when the host names match, else TCP.
Transport choose_transport(std::string_view my_host, bool dest_local, const Location& dest);

/// What a connect asks for (the node's `connect {out, to, in, set, mode, queue}` plus the source's name).
struct ConnectRequest {
  std::string from;  ///< source component (PATH)
  std::string out;   ///< its output port
  std::string to;    ///< destination component (PATH)
  std::string in;    ///< its input port
  std::string set;   ///< connection set
  Mode mode = Mode::Push;
  std::uint32_t queue = 16;  ///< the input's queue capacity for push connections (grown, never shrunk)
};

/// An event of the data plane, reported to Endpoint::on_event.
struct CommsEvent {
  enum class Kind : std::uint8_t { Broken, Overflow };
  Kind kind = Kind::Broken;
  std::string component;  ///< the local component concerned
  std::string port;       ///< its port
  std::string peer;       ///< the other end ("PATH.port" or an address)
  std::string set;        ///< the connection's set ("" when unknown)
  std::string reason;     ///< what happened
};

/// Statistics of one connection.
struct LinkInfo {
  ConnectRequest request;
  Transport transport = Transport::InProcess;
  bool active = false;
  bool broken = false;
  std::uint64_t sent = 0;     ///< samples handed to the transport
  std::uint64_t skipped = 0;  ///< samples not sent while the set was inactive
  std::uint64_t tx_dropped = 0;  ///< samples dropped because the socket was backed up beyond its limit
  std::uint64_t bytes = 0;    ///< bytes written to the socket (0 in-process)
};

/// One per process: the components' ports, the data listeners (Unix socket and TCP), the connections and
/// the connection sets. Runs on one io_context; not thread-safe (nothing in the data plane takes a lock).
class Endpoint {
 public:
  /// `host` is this process's logical host name (chooses Unix socket vs TCP).
  Endpoint(boost::asio::io_context& io, std::string host);
  ~Endpoint();
  Endpoint(const Endpoint&) = delete;
  Endpoint& operator=(const Endpoint&) = delete;

  /// Listens for data connections on a Unix socket at `path` (removed first if stale) and on TCP at
  /// `tcp_address` ("127.0.0.1:0" picks a free port). Throws std::runtime_error on failure.
  void listen(const std::string& uds_path, const std::string& tcp_address = "127.0.0.1:0");
  /// This endpoint's address, for the NameServer.
  Location location() const;
  /// The logical host name.
  const std::string& host() const { return host_; }

  /// Makes a component's ports reachable under `name` (PATH). Call remove_component before destroying the
  /// PortSet (connections also survive a port destroyed first: they stop delivering).
  void add_component(const std::string& name, PortSet& ports);
  /// Removes a component: its connections (both directions) are closed.
  void remove_component(const std::string& name);
  /// The component registered as `name`, or nullptr.
  PortSet* component(std::string_view name) const;

  /// Result of connect: "" on success, else the reason (names the valid ports when one is unknown).
  using ConnectDone = std::function<void(const std::string& error)>;
  /// Connects `r.from`.`r.out` (local) to `r.to`.`r.in`, local or at `dest`. Created inactive (or active at
  /// once if its set already is). `done` runs exactly once: on success, on refusal by the destination, or
  /// after `timeout_ms` without an answer. In-process connections complete before connect returns.
  void connect(const ConnectRequest& r, const Location& dest, ConnectDone done, int timeout_ms = 5000);
  /// Removes every connection of set `set` from this endpoint's outputs (their sockets are closed).
  void disconnect_set(const std::string& set);

  /// Activates a set: a flag flip, no socket opened. Pending pull requests of the set are answered.
  void activate(const std::string& set);
  /// Deactivates a set: a flag flip, no socket closed.
  void deactivate(const std::string& set);
  /// True when `set` is active.
  bool active(const std::string& set) const;

  /// Sets the callback for data-plane events (broken connections, first overflow of an input).
  void on_event(std::function<void(const CommsEvent&)> fn);

  /// Every connection from this endpoint's outputs.
  std::vector<LinkInfo> links() const;
  /// Number of data connections accepted from other processes and still open.
  std::size_t accepted() const;
  /// Total bytes received on accepted data connections.
  std::uint64_t bytes_received() const;

  /// Internal state shared with connections (comms.cpp).
  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
  std::string host_;
};

}  // namespace dca
