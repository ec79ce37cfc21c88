#pragma once
// Ports (pure: no I/O, no socket, no clock): named, typed inputs and outputs, what a connection between them
// asks for, and how it would travel (docs/data-plane.md; host/net/endpoint moves the samples). This is the node's
// side of a port; a controller sees PortSpec and its In<T>/Out<T> handles only (dca/port.h, the SDK), so nothing
// here is part of a package's ABI.
//
// A port carries samples of one type: a scalar (double), a fixed-size vector of doubles (Eigen), a
// dynamic-size vector of doubles (Eigen), or a msgpack value. An output feeds any number of inputs and an
// input is fed by any number of outputs, through the Links that host/net/endpoint attaches.
//
// Push connections deliver every sample into the input's bounded queue. Overflow policy: DROP-OLDEST: when
// the queue is full the oldest queued sample is discarded, counted in Input::dropped() and reported in the
// port statistics (and once through Input::on_overflow). Pull connections deliver nothing on their own: the
// reader asks (Input::request()) and the source answers with its latest sample.
//
// Threading: one thread (the process's io_context thread); nothing takes a lock. The hot-path calls
// (Output::write*, Input::pop/scalar/vector) do not allocate for scalar and fixed-size ports once the
// connection is made (dynamic vectors allocate only when a sample is bigger than any before; values allocate).
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>

#include "host/codec/msgs.h"
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <msgpack.hpp>

#include <dca/port.h>

#include "host/transport.h"

namespace dca {

/// A tap input (host/net/tap.h): a Value input named "tap:...", which takes stamped samples of any output.
bool is_tap_input(const PortSpec& in);

/// Why two ports cannot be connected ("" when they can): type or size differ.
std::string compatibility_error(const PortSpec& out, const PortSpec& in);

/// A port's counters (reported by the node's `ports {}` reply).
struct PortStats {
  std::uint64_t samples = 0;   ///< samples written (output) or received (input)
  std::uint64_t dropped = 0;   ///< input: queued samples dropped by the drop-oldest policy
  std::uint64_t rejected = 0;  ///< samples of the wrong size or malformed, refused and counted
  std::uint64_t skipped = 0;   ///< output: samples not sent because the connection's set was inactive
};

class Input;
class Output;

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
  /// A Message port's type (nullptr for the others).
  const msgs::TypeInfo* message() const { return message_; }
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
  const msgs::TypeInfo* message_ = nullptr;  ///< a Message port's type
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
  /// The writer whose samples this connection carries ("PATH.PORT"), as an exclusive input names it.
  virtual std::string writer() const { return {}; }
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
  /// What a controller's In<T>::read sees (dca/port.h): drains the queue, then New when the current sample was
  /// not read before (queued or a pull answer), Old when it was, None before any. Real-time safe.
  Read take_for_read();
  /// The current sample counts as read (a controller popped it).
  void mark_read() { unread_ = false; }

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
  /// A pushed sample of connection `from`: on an exclusive input, refused when another connection holds it
  /// (see set_exclusive); else as deliver. `from` is an identity: a connection no longer among the feeders
  /// (a sample held for it after it closed) is never dereferenced; on an exclusive input such a sample is
  /// dropped.
  void deliver_from(InputFeeder* from, Bytes b);
  /// One writer at a time (a robot's command input, docs/safety.md): the connection whose sample was taken
  /// last holds the input for one of its own periods after each sample (the ticks, tick(), between its last
  /// two; one tick before it has two; at most `max_lease_ticks`); a sample of another connection meanwhile is
  /// refused: counted, never delivered, and on_refused(writer, holder) runs. So two writers in the same tick, or
  /// interleaved, are refused, and a writer that follows another after its period takes over. 0: off.
  void set_exclusive(std::uint32_t max_lease_ticks);
  /// One actuator behind several inputs (a joint's alias beside its drive's vector input, docs/worlds.md): this
  /// input shares exclusive input `other`'s hold, so that a writer on either holds both and another writer on
  /// either is refused as a second writer. Its own lease is `other`'s; its tick() leaves the hold alone.
  void share_exclusive(Input& other);
  /// A tick of the clock that drives this input's owner (the world's step): the holder's lease runs down.
  void tick() {
    if (hold_ && owns_hold_) ++hold_->ticks;
  }
  /// Samples refused from a second writer.
  std::uint64_t refused() const { return refused_; }
  /// Runs at each refused sample with the refused writer and the one holding the input ("PATH.PORT").
  std::function<void(const std::string& writer, const std::string& holder)> on_refused;
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
  void take_queued();  // take_latest() when something is queued
  std::vector<std::vector<std::byte>> slots_;
  std::vector<std::size_t> sizes_;
  std::size_t head_ = 0, count_ = 0;
  std::vector<std::byte> current_;
  std::size_t current_size_ = 0;
  bool has_current_ = false;
  bool unread_ = false;  // the current sample has not been through take_for_read() yet
  std::vector<PullSource*> pull_sources_;
  std::vector<InputFeeder*> feeders_;
  bool warned_drop_ = false;
  // set_exclusive: who holds the input (or the actuator it shares with others), since when, for how long
  struct Hold {
    std::uint32_t max_lease = 0;
    const InputFeeder* holder = nullptr;  // the connection holding it
    std::uint64_t ticks = 0, held_at = 0, interval = 0;
  };
  std::shared_ptr<Hold> hold_;
  bool owns_hold_ = false;  // this input's tick() runs the hold's clock
  std::uint64_t refused_ = 0;
};

/// Lock-step delivery of one push connection (docs/time.md): the samples that arrived on it are
/// counted, and while the gate is closed to them a sample beyond the count the clock master released waits
/// here, in order, instead of reaching the input. So a reader at tick t takes exactly the samples its writers
/// wrote before t, whatever the transport and whichever process ran first. Open (gated false): every sample
/// goes straight through. Not real-time safe while holding (a held sample is copied).
class LinkGate {
 public:
  /// A sample of this connection (`from`, the connection feeding `in`) for `in`: delivered, or held while gated
  /// and beyond the released count.
  void deliver(Input& in, Bytes b, InputFeeder* from = nullptr);
  /// The master's count for this connection: held samples up to `n` go to `in`. Returns true when `n` samples
  /// have arrived.
  bool release(Input* in, std::uint64_t n);
  /// Samples arrived on this connection.
  std::uint64_t received() const { return received_; }
  /// The released count (the last `release`).
  std::uint64_t allowed() const { return allowed_; }
  /// Held samples and counts forgotten (a new connection under the same name).
  void reset();
  /// The connection this gate now belongs to: a sample of any other (the one it replaced, whose last samples
  /// may still arrive after the new one's hello) is dropped, never counted or delivered as the new one's.
  /// `sender` and `serial` are the hello's (data_frame::Hello): see `later`.
  void adopt(InputFeeder* feeder, std::uint64_t sender = 0, std::uint64_t serial = 0) {
    owner_ = feeder;
    sender_ = sender;
    serial_ = serial;
  }
  /// Whether a hello from `sender` numbered `serial` is later than the owner's: false only for an earlier hello
  /// of the same sender (a moved link's first hello read after its second, on the other socket).
  bool later(std::uint64_t sender, std::uint64_t serial) const {
    return sender == 0 || sender != sender_ || serial > serial_;
  }
  /// Samples dropped as a replaced connection's.
  std::uint64_t stale() const { return stale_; }
  bool gated = false;

 private:
  std::uint64_t received_ = 0, delivered_ = 0, allowed_ = 0, stale_ = 0;
  InputFeeder* owner_ = nullptr;  // adopt() (an identity, compared only: it may be gone)
  std::uint64_t sender_ = 0, serial_ = 0;  // the owner's hello
  InputFeeder* from_ = nullptr;  // the connection whose samples these are (an identity: it may be gone)
  std::vector<std::vector<std::byte>> held_;
  std::size_t held_head_ = 0;
};

/// A connection's sending side, attached to an output (host/net/endpoint implements it for each transport).
class Link {
 public:
  virtual ~Link() = default;
  /// A sample was written to the output. Real-time safe for the in-process transport.
  virtual void on_write(Bytes b) = 0;
  /// Detaches from both ends and closes any socket (also called when the output is destroyed).
  virtual void close() = 0;
};

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
  /// A digest of every sample written (FNV-1a over their 64-bit words, chained): what a trace compares.
  std::uint64_t digest() const { return digest_; }

 private:
  std::vector<Link*> links_;
  msgpack::sbuffer scratch_;
  std::uint64_t digest_ = 14695981039346656037ull;
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

// ------------------------------------------------------------------------------------------ connections ---

/// Push: every sample goes into the input's queue. Pull: the reader asks for the latest sample.
enum class Mode : std::uint8_t { Push, Pull };
/// "push" or "pull".
std::string_view to_string(Mode m);
/// The Mode named `s`, or nothing.
std::optional<Mode> mode_from(std::string_view s);

// How a connection travels: Transport (host/transport.h).

/// Where a destination component lives (from the NameServer's endpoints record).
struct Location {
  std::string host;      ///< logical host name
  std::string data_uds;  ///< its node's Unix-socket data endpoint (path)
  std::string data_tcp;  ///< its node's TCP data endpoint ("127.0.0.1:port")
  /// The leaf instance in its node (a shared node's add count; 0 for a one-leaf node): a leaf removed and added
  /// again in the same node lives at the same address, so this tells the new instance from the old one.
  std::uint64_t instance = 0;
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
  /// A tap's link (host/net/tap.h): each sample travels with the writer's clock time before it (8 bytes, host order),
  /// into a tap input (a Value input named "tap:..."), whatever the output's type.
  bool stamped = false;
};

/// The name of one connection in the lock-step's counts: "from|out>to|in@set" (paths and port names hold dots).
std::string link_key(const ConnectRequest& r);

}  // namespace dca
