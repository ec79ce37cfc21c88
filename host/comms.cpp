// Boost.Asio 1.74 under GCC 12 -O3 trips two middle-end warnings inside its own headers (a "potential null
// pointer dereference" in scheduler.ipp and a "maybe uninitialized" reactor_data_): false positives, silenced
// for this file only, before any include.
#pragma GCC diagnostic ignored "-Wnull-dereference"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

#include "host/comms.h"

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstring>
#include <set>
#include <stdexcept>

#include <boost/asio/connect.hpp>
#include <boost/asio/generic/stream_protocol.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/local/stream_protocol.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/write.hpp>

#include "host/comms_internal.h"

namespace asio = boost::asio;

namespace dca {

// ---------------------------------------------------------------------------------------------- names ---

std::string_view to_string(PortType t) {
  switch (t) {
    case PortType::Scalar: return "scalar";
    case PortType::Vector: return "vector";
    case PortType::VectorX: return "vectorx";
    case PortType::Value: return "value";
  }
  return "?";
}

std::optional<PortType> port_type_from(std::string_view s) {
  for (auto t : {PortType::Scalar, PortType::Vector, PortType::VectorX, PortType::Value})
    if (to_string(t) == s) return t;
  return std::nullopt;
}

std::string_view to_string(Mode m) { return m == Mode::Push ? "push" : "pull"; }

std::optional<Mode> mode_from(std::string_view s) {
  if (s == "push") return Mode::Push;
  if (s == "pull") return Mode::Pull;
  return std::nullopt;
}

std::string_view to_string(Transport t) {
  switch (t) {
    case Transport::InProcess: return "inprocess";
    case Transport::Unix: return "unix";
    case Transport::Tcp: return "tcp";
  }
  return "?";
}

PortSpec scalar_port(std::string name, std::string units) {
  return {std::move(name), PortType::Scalar, 1, std::move(units), {}};
}
PortSpec vector_port(std::string name, std::uint32_t size, std::string units) {
  return {std::move(name), PortType::Vector, size, std::move(units), {}};
}
PortSpec vectorx_port(std::string name, std::string units) {
  return {std::move(name), PortType::VectorX, 0, std::move(units), {}};
}
PortSpec value_port(std::string name, std::string units) {
  return {std::move(name), PortType::Value, 0, std::move(units), {}};
}

namespace {
std::string describe(const PortSpec& s) {
  std::string d(to_string(s.type));
  if (s.type == PortType::Vector) d += "[" + std::to_string(s.size) + "]";
  return d;
}
}  // namespace

std::string compatibility_error(const PortSpec& out, const PortSpec& in) {
  const bool ok = out.type == in.type && (out.type != PortType::Vector || out.size == in.size);
  if (ok) return "";
  return "output '" + out.name + "' is " + describe(out) + " but input '" + in.name + "' is " + describe(in);
}

Transport choose_transport(std::string_view my_host, bool dest_local, const Location& dest) {
  if (dest_local) return Transport::InProcess;
  if (dest.host == my_host && !dest.data_uds.empty()) return Transport::Unix;
  return Transport::Tcp;
}

// ---------------------------------------------------------------------------------------------- ports ---

Port::Port(PortSpec spec) : spec_(std::move(spec)) {
  if (spec_.type == PortType::Scalar) spec_.size = 1;
  if (spec_.type == PortType::VectorX || spec_.type == PortType::Value) spec_.size = 0;
  latest_.resize(std::max<std::size_t>(spec_.size, 1) * sizeof(double));
}

void Port::set_latest(Bytes b) {
  if (latest_.size() < b.size()) latest_.resize(b.size());
  if (!b.empty()) std::memcpy(latest_.data(), b.data(), b.size());
  latest_size_ = b.size();
  has_latest_ = true;
}

bool Port::accepts(Bytes b) {
  bool ok = false;
  switch (spec_.type) {
    case PortType::Scalar: ok = b.size() == sizeof(double); break;
    case PortType::Vector: ok = b.size() == spec_.size * sizeof(double); break;
    case PortType::VectorX: ok = b.size() % sizeof(double) == 0; break;
    case PortType::Value: ok = !b.empty(); break;
  }
  if (!ok) ++stats_.rejected;
  return ok;
}

namespace {
void pack_sample(msgpack::packer<msgpack::sbuffer>& pk, PortType type, Bytes b, bool present) {
  if (!present) {
    pk.pack_nil();
    return;
  }
  if (type == PortType::Value) {
    try {
      auto oh = msgpack::unpack(reinterpret_cast<const char*>(b.data()), b.size());
      pk.pack(oh.get());
    } catch (const std::exception&) {
      pk.pack_nil();
    }
    return;
  }
  const std::size_t n = b.size() / sizeof(double);
  auto at = [&](std::size_t i) {
    double d;
    std::memcpy(&d, b.data() + i * sizeof(double), sizeof d);
    return d;
  };
  if (type == PortType::Scalar) {
    pk.pack_double(n ? at(0) : 0.0);
    return;
  }
  pk.pack_array(static_cast<std::uint32_t>(n));
  for (std::size_t i = 0; i < n; ++i) pk.pack_double(at(i));
}
}  // namespace

void Port::pack_latest(msgpack::packer<msgpack::sbuffer>& pk) const {
  pack_sample(pk, spec_.type, latest_bytes(), has_latest_);
}

Input::Input(PortSpec spec, std::size_t queue) : Port(std::move(spec)) {
  current_.resize(latest_.size());
  reserve_queue(std::max<std::size_t>(queue, 1));
}

Input::~Input() {
  for (auto* f : std::vector<InputFeeder*>(feeders_)) f->input_gone();
}

void Input::add_feeder(InputFeeder* f) { feeders_.push_back(f); }
void Input::remove_feeder(InputFeeder* f) { std::erase(feeders_, f); }

void Input::reserve_queue(std::size_t n) {
  if (n <= slots_.size()) return;
  // Re-linearise the ring into the new, larger one.
  std::vector<std::vector<std::byte>> slots(n, std::vector<std::byte>(latest_.size()));
  std::vector<std::size_t> sizes(n, 0);
  for (std::size_t i = 0; i < count_; ++i) {
    const std::size_t j = (head_ + i) % slots_.size();
    slots[i] = std::move(slots_[j]);
    sizes[i] = sizes_[j];
  }
  slots_ = std::move(slots);
  sizes_ = std::move(sizes);
  head_ = 0;
}

void Input::deliver(Bytes b) {
  if (!accepts(b)) return;
  ++stats_.samples;
  set_latest(b);
  const std::size_t cap = slots_.size();
  if (count_ == cap) {  // drop-oldest
    head_ = (head_ + 1) % cap;
    --count_;
    ++stats_.dropped;
    if (!warned_drop_) {
      warned_drop_ = true;
      if (on_overflow) on_overflow();
    }
  }
  const std::size_t tail = (head_ + count_) % cap;
  auto& slot = slots_[tail];
  if (slot.size() < b.size()) slot.resize(b.size());
  if (!b.empty()) std::memcpy(slot.data(), b.data(), b.size());
  sizes_[tail] = b.size();
  ++count_;
  if (on_sample) on_sample();
}

void Input::deliver_pulled(Bytes b) {
  if (!accepts(b)) return;
  ++stats_.samples;
  set_latest(b);
  if (current_.size() < b.size()) current_.resize(b.size());
  if (!b.empty()) std::memcpy(current_.data(), b.data(), b.size());
  current_size_ = b.size();
  has_current_ = true;
  if (on_sample) on_sample();
}

void Input::make_current(const std::vector<std::byte>& b, std::size_t n) {
  if (current_.size() < n) current_.resize(n);
  if (n) std::memcpy(current_.data(), b.data(), n);
  current_size_ = n;
  has_current_ = true;
}

bool Input::pop() {
  if (count_ == 0) return false;
  make_current(slots_[head_], sizes_[head_]);
  head_ = (head_ + 1) % slots_.size();
  --count_;
  return true;
}

bool Input::take_latest() {
  if (count_ == 0) return false;
  const std::size_t last = (head_ + count_ - 1) % slots_.size();
  make_current(slots_[last], sizes_[last]);
  head_ = 0;
  count_ = 0;
  return true;
}

void Input::request() {
  for (auto* s : pull_sources_) s->request();
}

double Input::scalar() const {
  if (current_size_ < sizeof(double)) return 0.0;
  double d;
  std::memcpy(&d, current_.data(), sizeof d);
  return d;
}

Eigen::Map<const Eigen::VectorXd> Input::vector() const {
  return {reinterpret_cast<const double*>(current_.data()),
          static_cast<Eigen::Index>(current_size_ / sizeof(double))};
}

msgpack::object_handle Input::value() const {
  if (!has_current_ || current_size_ == 0) return msgpack::object_handle();
  return msgpack::unpack(reinterpret_cast<const char*>(current_.data()), current_size_);
}

void Input::add_pull_source(PullSource* s) { pull_sources_.push_back(s); }
void Input::remove_pull_source(PullSource* s) { std::erase(pull_sources_, s); }

// A connection's sending side: gets every sample written to its output.
class Link {
 public:
  Link(ConnectRequest r, Transport t, Output* out, std::shared_ptr<bool> active)
      : out_(out), active_(std::move(active)) {
    info_.request = std::move(r);
    info_.transport = t;
  }
  virtual ~Link() = default;
  Link(const Link&) = delete;
  Link& operator=(const Link&) = delete;
  /// A sample was written to the output.
  virtual void on_write(Bytes b) = 0;
  /// The set became active.
  virtual void on_activate() {}
  /// Detaches from both ends and closes any socket.
  virtual void close() {
    if (out_) out_->detach(this);
    out_ = nullptr;
  }
  LinkInfo info() const {
    LinkInfo i = info_;
    i.active = *active_;
    return i;
  }
  const ConnectRequest& request() const { return info_.request; }

 protected:
  Output* out_;
  std::shared_ptr<bool> active_;
  LinkInfo info_;
};

Output::Output(PortSpec spec) : Port(std::move(spec)) {}

Output::~Output() {
  for (auto* l : std::vector<Link*>(links_)) l->close();
}

bool Output::write(double v) {
  if (spec_.type != PortType::Scalar) {
    ++stats_.rejected;
    return false;
  }
  return write_bytes({reinterpret_cast<const std::byte*>(&v), sizeof v});
}

bool Output::write(const Eigen::Ref<const Eigen::VectorXd>& v) {
  if (spec_.type != PortType::Vector && spec_.type != PortType::VectorX) {
    ++stats_.rejected;
    return false;
  }
  return write_bytes({reinterpret_cast<const std::byte*>(v.data()), static_cast<std::size_t>(v.size()) * sizeof(double)});
}

bool Output::write_bytes(Bytes b) {
  if (!accepts(b)) return false;
  ++stats_.samples;
  set_latest(b);
  for (std::size_t i = 0; i < links_.size(); ++i) links_[i]->on_write(b);
  return true;
}

void Output::attach(Link* l) { links_.push_back(l); }
void Output::detach(Link* l) { std::erase(links_, l); }

Input& PortSet::add_input(PortSpec spec, std::size_t queue) {
  if (find_input(spec.name)) throw std::invalid_argument("input '" + spec.name + "' declared twice");
  inputs_.push_back(std::make_unique<Input>(std::move(spec), queue));
  return *inputs_.back();
}

Output& PortSet::add_output(PortSpec spec) {
  if (find_output(spec.name)) throw std::invalid_argument("output '" + spec.name + "' declared twice");
  outputs_.push_back(std::make_unique<Output>(std::move(spec)));
  return *outputs_.back();
}

Input* PortSet::find_input(std::string_view name) const {
  for (const auto& p : inputs_)
    if (p->name() == name) return p.get();
  return nullptr;
}

Output* PortSet::find_output(std::string_view name) const {
  for (const auto& p : outputs_)
    if (p->name() == name) return p.get();
  return nullptr;
}

namespace {
template <class V>
std::string no_such(std::string_view what, std::string_view component, std::string_view name, const V& ports) {
  std::string m = "no " + std::string(what) + " '" + std::string(name) + "' on " + std::string(component);
  if (ports.empty()) return m + "; it has no " + std::string(what) + "s";
  m += "; " + std::string(what) + "s are: ";
  for (std::size_t i = 0; i < ports.size(); ++i) m += (i ? ", " : "") + ports[i]->name();
  return m;
}
}  // namespace

std::string PortSet::no_such_input(std::string_view component, std::string_view name) const {
  return no_such("input", component, name, inputs_);
}
std::string PortSet::no_such_output(std::string_view component, std::string_view name) const {
  return no_such("output", component, name, outputs_);
}

// ---------------------------------------------------------------------------------------------- frames ---

namespace comms {

void put_header(std::byte* h, Kind kind, std::size_t body_size) {
  const auto len = static_cast<std::uint32_t>(body_size + 1);
  h[0] = static_cast<std::byte>(len >> 24);
  h[1] = static_cast<std::byte>(len >> 16);
  h[2] = static_cast<std::byte>(len >> 8);
  h[3] = static_cast<std::byte>(len);
  h[4] = static_cast<std::byte>(kind);
}

Parse parse_frame(Bytes buf, Frame& f, std::size_t& used, std::string& error) {
  used = 0;
  if (buf.size() < 4) return Parse::NeedMore;
  const std::uint32_t len = (std::to_integer<std::uint32_t>(buf[0]) << 24) |
                            (std::to_integer<std::uint32_t>(buf[1]) << 16) |
                            (std::to_integer<std::uint32_t>(buf[2]) << 8) | std::to_integer<std::uint32_t>(buf[3]);
  if (len == 0) {
    error = "empty data frame";
    return Parse::Error;
  }
  if (len > kMaxFrame) {
    error = "data frame of " + std::to_string(len) + " bytes exceeds the limit of " + std::to_string(kMaxFrame);
    return Parse::Error;
  }
  if (buf.size() < 4 + static_cast<std::size_t>(len)) {
    used = 4 + static_cast<std::size_t>(len);
    return Parse::NeedMore;
  }
  const auto k = std::to_integer<std::uint8_t>(buf[4]);
  if (k < 1 || k > 6) {
    error = "unknown data frame kind " + std::to_string(k);
    return Parse::Error;
  }
  f.kind = static_cast<Kind>(k);
  f.body = buf.subspan(5, len - 1);
  used = 4 + static_cast<std::size_t>(len);
  return Parse::Ok;
}

std::string encode_hello(const Hello& h) {
  msgpack::sbuffer sb;
  msgpack::packer<msgpack::sbuffer> pk(sb);
  const auto& r = h.request;
  pk.pack_map(9);
  pk.pack("from"), pk.pack(r.from);
  pk.pack("out"), pk.pack(r.out);
  pk.pack("to"), pk.pack(r.to);
  pk.pack("in"), pk.pack(r.in);
  pk.pack("set"), pk.pack(r.set);
  pk.pack("mode"), pk.pack(std::string(to_string(r.mode)));
  pk.pack("queue"), pk.pack(r.queue);
  pk.pack("type"), pk.pack(std::string(to_string(h.out.type)));
  pk.pack("size"), pk.pack(h.out.size);
  return {sb.data(), sb.size()};
}

bool decode_hello(Bytes body, Hello& h, std::string& error) {
  try {
    auto oh = msgpack::unpack(reinterpret_cast<const char*>(body.data()), body.size());
    const auto& o = oh.get();
    if (o.type != msgpack::type::MAP) {
      error = "hello is not a map";
      return false;
    }
    std::string mode = "push", type;
    bool have_type = false;
    for (std::uint32_t i = 0; i < o.via.map.size; ++i) {
      const auto& kv = o.via.map.ptr[i];
      if (kv.key.type != msgpack::type::STR) continue;
      const std::string k = kv.key.as<std::string>();
      if (k == "from") h.request.from = kv.val.as<std::string>();
      else if (k == "out") h.request.out = kv.val.as<std::string>();
      else if (k == "to") h.request.to = kv.val.as<std::string>();
      else if (k == "in") h.request.in = kv.val.as<std::string>();
      else if (k == "set") h.request.set = kv.val.as<std::string>();
      else if (k == "mode") mode = kv.val.as<std::string>();
      else if (k == "queue") h.request.queue = kv.val.as<std::uint32_t>();
      else if (k == "type") type = kv.val.as<std::string>(), have_type = true;
      else if (k == "size") h.out.size = kv.val.as<std::uint32_t>();
    }
    const auto m = mode_from(mode);
    const auto t = port_type_from(type);
    if (!m) error = "hello: unknown mode '" + mode + "'";
    else if (!have_type || !t) error = "hello: unknown port type '" + type + "'";
    else if (h.request.to.empty() || h.request.in.empty()) error = "hello: no destination named";
    if (!error.empty()) return false;
    h.request.mode = *m;
    h.out.type = *t;
    h.out.name = h.request.out;
    return true;
  } catch (const std::exception& e) {
    error = std::string("malformed hello: ") + e.what();
    return false;
  }
}

}  // namespace comms

// ---------------------------------------------------------------------------------------------- endpoint ---

using Socket = asio::generic::stream_protocol::socket;
using comms::Kind;
namespace comms {
class Session;
}

struct Endpoint::Impl {
  Impl(asio::io_context& io_, std::string host_) : io(io_), host(std::move(host_)) {}
  asio::io_context& io;
  std::string host;
  std::map<std::string, PortSet*, std::less<>> components;
  std::map<std::string, std::shared_ptr<bool>, std::less<>> sets;
  std::vector<std::shared_ptr<Link>> links;
  std::set<std::shared_ptr<comms::Session>> sessions;
  std::unique_ptr<asio::local::stream_protocol::acceptor> uds_acceptor;
  std::unique_ptr<asio::ip::tcp::acceptor> tcp_acceptor;
  std::string uds_path, tcp_address;
  std::uint64_t bytes_received = 0;
  bool closing = false;

  std::shared_ptr<bool> set_flag(const std::string& name) {
    auto it = sets.find(name);
    if (it != sets.end()) return it->second;
    return sets.emplace(name, std::make_shared<bool>(false)).first->second;
  }
  void report(CommsEvent e) {
    if (on_event && !closing) on_event(e);
  }
  void remove_link(Link* l) {
    for (auto it = links.begin(); it != links.end(); ++it)
      if (it->get() == l) {
        auto keep = *it;  // the link may be running one of its own handlers
        links.erase(it);
        keep->close();
        return;
      }
  }
  /// Validates a connection's destination: "" when `r.to`.`r.in` exists here and accepts `out`.
  std::string check_destination(const ConnectRequest& r, const PortSpec& out, Input*& in) const {
    auto it = components.find(r.to);
    if (it == components.end()) return "no component '" + r.to + "' at " + host;
    in = it->second->find_input(r.in);
    if (!in) return it->second->no_such_input(r.to, r.in);
    return compatibility_error(out, in->spec());
  }
  void accept_uds();
  void accept_tcp();
  void start_session(Socket s);

  std::function<void(const CommsEvent&)> on_event;
};

namespace comms {

constexpr std::size_t kMaxBacklog = 8u << 20;  // bytes waiting on a backed-up socket before samples are dropped

// Frame I/O on one data socket (both ends use it): synchronous non-blocking writes first, async for the rest.
class Wire : public std::enable_shared_from_this<Wire> {
 public:
  explicit Wire(Socket s) : sock_(std::move(s)) { rbuf_.resize(64 * 1024); }
  virtual ~Wire() = default;
  Wire(const Wire&) = delete;
  Wire& operator=(const Wire&) = delete;

  /// Sends a frame; false when the backlog is full (the frame is dropped) or the socket is closed.
  bool send(Kind kind, Bytes body) {
    if (closed_) return false;
    std::array<std::byte, comms::kHeader> h;
    comms::put_header(h.data(), kind, body.size());
    const std::size_t total = h.size() + body.size();
    if (!writing_ && pending_.empty()) {
      const std::array<asio::const_buffer, 2> bufs{asio::buffer(h.data(), h.size()), asio::buffer(body.data(), body.size())};
      boost::system::error_code ec;
      const std::size_t n = sock_.write_some(bufs, ec);
      bytes_out_ += n;
      if (!ec && n == total) return true;
      if (ec && ec != asio::error::would_block && ec != asio::error::try_again) {
        fail(ec.message());
        return false;
      }
      append_from(h, body, n);
      start_write();
      return true;
    }
    if (pending_.size() > kMaxBacklog) return false;
    append_from(h, body, 0);
    if (!writing_) start_write();
    return true;
  }

  void start_read() {
    if (closed_) return;
    if (rbuf_.size() - rlen_ < 1024) rbuf_.resize(rbuf_.size() * 2);
    sock_.async_read_some(asio::buffer(rbuf_.data() + rlen_, rbuf_.size() - rlen_),
                          [self = shared_from_this()](const boost::system::error_code& ec, std::size_t n) {
                            self->on_read(ec, n);
                          });
  }

  /// Closes the socket; pending handlers find closed_ set and return.
  void shut() {
    if (closed_) return;
    closed_ = true;
    boost::system::error_code ec;
    sock_.shutdown(asio::socket_base::shutdown_both, ec);
    sock_.close(ec);
  }

  /// Closes once everything queued is written (the error reply of a refused hello).
  void close_after_flush() {
    if (!writing_ && pending_.empty()) shut();
    else close_after_flush_ = true;
  }

  std::uint64_t bytes_out() const { return bytes_out_; }
  bool closed() const { return closed_; }

 protected:
  virtual void on_frame(Kind kind, Bytes body) = 0;
  virtual void on_broken(const std::string& reason) = 0;
  virtual void on_bytes(std::size_t) {}

  void fail(const std::string& reason) {
    if (closed_) return;
    shut();
    on_broken(reason);
  }

  Socket sock_;

 private:
  void append_from(const std::array<std::byte, comms::kHeader>& h, Bytes body, std::size_t skip) {
    if (skip < h.size()) pending_.insert(pending_.end(), h.begin() + static_cast<std::ptrdiff_t>(skip), h.end());
    const std::size_t bskip = skip > h.size() ? skip - h.size() : 0;
    pending_.insert(pending_.end(), body.begin() + static_cast<std::ptrdiff_t>(bskip), body.end());
  }

  void start_write() {
    if (closed_ || pending_.empty()) return;
    inflight_.swap(pending_);
    pending_.clear();
    writing_ = true;
    asio::async_write(sock_, asio::buffer(inflight_),
                      [self = shared_from_this()](const boost::system::error_code& ec, std::size_t n) {
                        self->writing_ = false;
                        self->bytes_out_ += n;
                        self->inflight_.clear();
                        if (self->closed_) return;
                        if (ec) return self->fail(ec.message());
                        if (!self->pending_.empty()) return self->start_write();
                        if (self->close_after_flush_) self->shut();
                      });
  }

  void on_read(const boost::system::error_code& ec, std::size_t n) {
    if (closed_) return;
    if (ec) return fail(ec == asio::error::eof ? "closed by peer" : ec.message());
    rlen_ += n;
    on_bytes(n);
    std::size_t off = 0;
    for (;;) {
      comms::Frame f;
      std::size_t used = 0;
      std::string error;
      const auto r = comms::parse_frame({rbuf_.data() + off, rlen_ - off}, f, used, error);
      if (r == comms::Parse::Error) return fail("malformed data frame: " + error);
      if (r == comms::Parse::NeedMore) {
        if (used > rbuf_.size()) rbuf_.resize(used);
        break;
      }
      on_frame(f.kind, f.body);
      if (closed_) return;
      off += used;
    }
    if (off) {
      std::memmove(rbuf_.data(), rbuf_.data() + off, rlen_ - off);
      rlen_ -= off;
    }
    start_read();
  }

  std::vector<std::byte> rbuf_;
  std::size_t rlen_ = 0;
  std::vector<std::byte> pending_, inflight_;
  bool writing_ = false, closed_ = false, close_after_flush_ = false;
  std::uint64_t bytes_out_ = 0;
};

Bytes as_bytes(const std::string& s) { return {reinterpret_cast<const std::byte*>(s.data()), s.size()}; }

// In-process connection: the sample is copied straight into the input.
class LocalLink final : public Link, public PullSource, public InputFeeder {
 public:
  LocalLink(ConnectRequest r, Output* out, Input* in, std::shared_ptr<bool> active)
      : Link(std::move(r), Transport::InProcess, out, std::move(active)), in_(in) {
    in_->add_feeder(this);
    if (info_.request.mode == Mode::Pull) in_->add_pull_source(this);
    else in_->reserve_queue(info_.request.queue);
    out_->attach(this);
  }
  ~LocalLink() override { LocalLink::close(); }
  void on_write(Bytes b) override {
    if (info_.request.mode == Mode::Pull) {
      if (pending_ && *active_) answer();
      return;
    }
    if (!*active_ || !in_) {
      ++info_.skipped;
      return;
    }
    ++info_.sent;
    in_->deliver(b);
  }
  void input_gone() override { in_ = nullptr; }
  void request() override {
    pending_ = true;
    if (*active_) answer();
  }
  void on_activate() override {
    if (pending_) answer();
  }
  void close() override {
    if (in_) {
      in_->remove_feeder(this);
      in_->remove_pull_source(this);
    }
    in_ = nullptr;
    Link::close();
  }

 private:
  void answer() {
    if (!out_ || !in_ || !out_->has_latest()) return;
    pending_ = false;
    ++info_.sent;
    in_->deliver_pulled(out_->latest_bytes());
  }
  Input* in_;
  bool pending_ = false;
};

// The sending side of a socket connection.
class StreamLink final : public Link, public Wire {
 public:
  StreamLink(Endpoint::Impl& ep, ConnectRequest r, Transport t, Output* out, std::shared_ptr<bool> active)
      : Link(std::move(r), t, out, std::move(active)), Wire(Socket(ep.io)), ep_(&ep), timer_(ep.io) {}

  void start(const Location& dest, Endpoint::ConnectDone done, int timeout_ms) {
    done_ = std::move(done);
    peer_ = info_.request.to + "." + info_.request.in;
    asio::generic::stream_protocol::endpoint where;
    try {
      if (info_.transport == Transport::Unix) {
        where = asio::local::stream_protocol::endpoint(dest.data_uds);
        peer_addr_ = dest.data_uds;
      } else {
        const auto colon = dest.data_tcp.rfind(':');
        if (colon == std::string::npos) throw std::invalid_argument("bad TCP address '" + dest.data_tcp + "'");
        where = asio::ip::tcp::endpoint(asio::ip::make_address(dest.data_tcp.substr(0, colon)),
                                        static_cast<unsigned short>(std::stoi(dest.data_tcp.substr(colon + 1))));
        peer_addr_ = dest.data_tcp;
      }
    } catch (const std::exception& e) {
      return finish(std::string("cannot connect to ") + peer_ + ": " + e.what());
    }
    auto self = std::static_pointer_cast<StreamLink>(shared_from_this());
    timer_.expires_after(std::chrono::milliseconds(timeout_ms));
    timer_.async_wait([self, timeout_ms](const boost::system::error_code& ec) {
      if (ec || self->connected_ || !self->done_) return;
      self->finish("no answer from " + self->peer_ + " at " + self->peer_addr_ + " within " +
                   std::to_string(timeout_ms) + " ms");
    });
    sock_.async_connect(where, [self](const boost::system::error_code& ec) {
      if (self->closed() || !self->done_) return;
      if (ec) return self->finish("cannot connect to " + self->peer_ + " at " + self->peer_addr_ + ": " + ec.message());
      boost::system::error_code ignored;
      if (self->info_.transport == Transport::Tcp) {
        const int one = 1;
        ::setsockopt(self->sock_.native_handle(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
      }
      self->sock_.non_blocking(true, ignored);
      comms::Hello h{self->info_.request, self->out_ ? self->out_->spec() : PortSpec{}};
      self->send(Kind::Hello, as_bytes(comms::encode_hello(h)));
      self->start_read();
    });
  }

  void on_write(Bytes b) override {
    if (!connected_ || info_.broken) return;
    if (info_.request.mode == Mode::Pull) {
      if (pending_ && *active_) answer();
      return;
    }
    if (!*active_) {
      ++info_.skipped;
      return;
    }
    if (send(Kind::Sample, b)) ++info_.sent;
    else ++info_.tx_dropped;
    info_.bytes = bytes_out();
  }

  void on_activate() override {
    if (pending_ && connected_) answer();
  }

  void close() override {
    Link::close();
    ep_ = nullptr;
    timer_.cancel();
    shut();
  }

 protected:
  void on_frame(Kind kind, Bytes body) override {
    switch (kind) {
      case Kind::HelloOk:
        if (connected_) break;
        connected_ = true;
        timer_.cancel();
        if (done_) std::exchange(done_, nullptr)("");
        if (pending_ && *active_) answer();
        return;
      case Kind::HelloError:
        return finish(std::string(reinterpret_cast<const char*>(body.data()), body.size()));
      case Kind::PullRequest:
        pending_ = true;
        if (*active_) answer();
        return;
      default:
        break;
    }
    fail("unexpected data frame kind " + std::to_string(static_cast<int>(kind)) + " from " + peer_);
  }

  void on_broken(const std::string& reason) override {
    if (done_) return finish("connection to " + peer_ + " closed before it was accepted: " + reason);
    info_.broken = true;
    if (ep_)
      ep_->report({CommsEvent::Kind::Broken, info_.request.from, info_.request.out, peer_, info_.request.set,
                   reason});
  }

 private:
  void answer() {
    if (!out_ || !out_->has_latest()) return;
    pending_ = false;
    if (send(Kind::Pulled, out_->latest_bytes())) ++info_.sent;
    info_.bytes = bytes_out();
  }
  // Connect failed: report once, then remove this link.
  void finish(const std::string& error) {
    auto done = std::exchange(done_, nullptr);
    auto* ep = ep_;
    timer_.cancel();
    shut();
    if (ep) ep->remove_link(this);
    if (done) done(error);
  }

  Endpoint::Impl* ep_;
  asio::steady_timer timer_;
  Endpoint::ConnectDone done_;
  std::string peer_, peer_addr_;
  bool connected_ = false;
  bool pending_ = false;
};

// The receiving side of a socket connection: feeds one local input.
class Session final : public Wire, public PullSource, public InputFeeder {
 public:
  Session(Endpoint::Impl& ep, Socket s) : Wire(std::move(s)), ep_(&ep) {}
  void begin() {
    boost::system::error_code ignored;
    sock_.non_blocking(true, ignored);
    start_read();
  }
  void request() override { send(Kind::PullRequest, {}); }
  void input_gone() override {
    in_ = nullptr;
    ep_ = nullptr;
    shut();
  }
  void close() {
    if (in_) {
      in_->remove_feeder(this);
      in_->remove_pull_source(this);
    }
    in_ = nullptr;
    ep_ = nullptr;
    shut();
  }
  const std::string& to() const { return hello_.request.to; }

 protected:
  void on_bytes(std::size_t n) override {
    if (ep_) ep_->bytes_received += n;
  }
  void on_frame(Kind kind, Bytes body) override {
    if (!ep_) return;
    if (!in_) {
      std::string error;
      if (kind != Kind::Hello) error = "the first data frame must be a hello";
      else if (comms::decode_hello(body, hello_, error)) error = ep_->check_destination(hello_.request, hello_.out, in_);
      if (!error.empty()) {
        in_ = nullptr;
        send(Kind::HelloError, as_bytes(error));
        close_after_flush();
        auto self = std::static_pointer_cast<Session>(shared_from_this());
        ep_->sessions.erase(self);
        return;
      }
      in_->add_feeder(this);
      if (hello_.request.mode == Mode::Pull) in_->add_pull_source(this);
      else in_->reserve_queue(hello_.request.queue);
      send(Kind::HelloOk, {});
      return;
    }
    if (kind == Kind::Sample) in_->deliver(body);
    else if (kind == Kind::Pulled) in_->deliver_pulled(body);
    else fail("unexpected data frame kind " + std::to_string(static_cast<int>(kind)));
  }
  void on_broken(const std::string& reason) override {
    auto* ep = ep_;
    if (!ep) return;
    if (in_)
      ep->report({CommsEvent::Kind::Broken, hello_.request.to, hello_.request.in,
                  hello_.request.from + "." + hello_.request.out, hello_.request.set, reason});
    close();
    ep->sessions.erase(std::static_pointer_cast<Session>(shared_from_this()));
  }

 private:
  Endpoint::Impl* ep_;
  comms::Hello hello_;
  Input* in_ = nullptr;
};

}  // namespace comms

using comms::LocalLink;
using comms::Session;
using comms::StreamLink;

void Endpoint::Impl::start_session(Socket s) {
  auto session = std::make_shared<Session>(*this, std::move(s));
  sessions.insert(session);
  session->begin();
}

void Endpoint::Impl::accept_uds() {
  if (!uds_acceptor) return;
  uds_acceptor->async_accept([this](const boost::system::error_code& ec, asio::local::stream_protocol::socket s) {
    if (ec == asio::error::operation_aborted || closing) return;
    if (!ec) {
      Socket g(io);
      boost::system::error_code e2;
      g.assign(asio::generic::stream_protocol(AF_UNIX, 0), s.release(), e2);
      if (!e2) start_session(std::move(g));
    }
    accept_uds();
  });
}

void Endpoint::Impl::accept_tcp() {
  if (!tcp_acceptor) return;
  tcp_acceptor->async_accept([this](const boost::system::error_code& ec, asio::ip::tcp::socket s) {
    if (ec == asio::error::operation_aborted || closing) return;
    if (!ec) {
      boost::system::error_code e2;
      s.set_option(asio::ip::tcp::no_delay(true), e2);
      const int family = s.local_endpoint(e2).protocol().family();
      Socket g(io);
      g.assign(asio::generic::stream_protocol(family, IPPROTO_TCP), s.release(), e2);
      if (!e2) start_session(std::move(g));
    }
    accept_tcp();
  });
}

Endpoint::Endpoint(asio::io_context& io, std::string host)
    : impl_(std::make_unique<Impl>(io, host)), host_(std::move(host)) {}

Endpoint::~Endpoint() {
  impl_->closing = true;
  boost::system::error_code ec;
  if (impl_->uds_acceptor) impl_->uds_acceptor->close(ec);
  if (impl_->tcp_acceptor) impl_->tcp_acceptor->close(ec);
  if (!impl_->uds_path.empty()) ::unlink(impl_->uds_path.c_str());
  for (auto& l : impl_->links) l->close();
  for (auto& s : std::set<std::shared_ptr<Session>>(impl_->sessions)) s->close();
}

void Endpoint::listen(const std::string& uds_path, const std::string& tcp_address) {
  if (!uds_path.empty()) {
    ::unlink(uds_path.c_str());
    impl_->uds_acceptor = std::make_unique<asio::local::stream_protocol::acceptor>(
        impl_->io, asio::local::stream_protocol::endpoint(uds_path));
    impl_->uds_path = uds_path;
    impl_->accept_uds();
  }
  if (!tcp_address.empty()) {
    const auto colon = tcp_address.rfind(':');
    if (colon == std::string::npos) throw std::runtime_error("bad TCP address '" + tcp_address + "' (want HOST:PORT)");
    const asio::ip::tcp::endpoint ep(asio::ip::make_address(tcp_address.substr(0, colon)),
                                     static_cast<unsigned short>(std::stoi(tcp_address.substr(colon + 1))));
    impl_->tcp_acceptor = std::make_unique<asio::ip::tcp::acceptor>(impl_->io, ep);
    const auto bound = impl_->tcp_acceptor->local_endpoint();
    impl_->tcp_address = bound.address().to_string() + ":" + std::to_string(bound.port());
    impl_->accept_tcp();
  }
}

Location Endpoint::location() const { return {host_, impl_->uds_path, impl_->tcp_address}; }

void Endpoint::add_component(const std::string& name, PortSet& ports) {
  if (impl_->components.count(name)) throw std::invalid_argument("component '" + name + "' is already registered");
  impl_->components.emplace(name, &ports);
  for (const auto& in : ports.inputs()) {
    Input* p = in.get();
    p->on_overflow = [this, name, p] {
      impl_->report({CommsEvent::Kind::Overflow, name, p->name(), "", "",
                     "queue of " + std::to_string(p->capacity()) + " full: dropping the oldest samples (counted)"});
    };
  }
}

void Endpoint::remove_component(const std::string& name) {
  auto it = impl_->components.find(name);
  if (it == impl_->components.end()) return;
  for (const auto& in : it->second->inputs()) in->on_overflow = nullptr;
  std::vector<std::shared_ptr<Link>> keep;
  for (auto& l : impl_->links) {
    if (l->request().from == name || (l->info().transport == Transport::InProcess && l->request().to == name)) l->close();
    else keep.push_back(l);
  }
  impl_->links.swap(keep);
  for (auto& s : std::set<std::shared_ptr<Session>>(impl_->sessions))
    if (s->to() == name) {
      s->close();
      impl_->sessions.erase(s);
    }
  impl_->components.erase(it);
}

PortSet* Endpoint::component(std::string_view name) const {
  auto it = impl_->components.find(name);
  return it == impl_->components.end() ? nullptr : it->second;
}

void Endpoint::connect(const ConnectRequest& r, const Location& dest, ConnectDone done, int timeout_ms) {
  auto* from = component(r.from);
  if (!from) return done("no component '" + r.from + "' at " + host_);
  Output* out = from->find_output(r.out);
  if (!out) return done(from->no_such_output(r.from, r.out));
  for (const auto& l : impl_->links) {
    const auto& q = l->request();
    if (q.from == r.from && q.out == r.out && q.to == r.to && q.in == r.in && q.set == r.set) return done("");
  }
  const Transport t = choose_transport(host_, component(r.to) != nullptr, dest);
  auto flag = impl_->set_flag(r.set);
  if (t == Transport::InProcess) {
    Input* in = nullptr;
    const std::string error = impl_->check_destination(r, out->spec(), in);
    if (!error.empty()) return done(error);
    impl_->links.push_back(std::make_shared<LocalLink>(r, out, in, flag));
    return done("");
  }
  auto link = std::make_shared<StreamLink>(*impl_, r, t, out, flag);
  out->attach(link.get());
  impl_->links.push_back(link);
  link->start(dest, std::move(done), timeout_ms);
}

void Endpoint::disconnect_set(const std::string& set) {
  std::vector<std::shared_ptr<Link>> keep;
  for (auto& l : impl_->links) {
    if (l->request().set == set) l->close();
    else keep.push_back(l);
  }
  impl_->links.swap(keep);
}

void Endpoint::activate(const std::string& set) {
  *impl_->set_flag(set) = true;
  for (std::size_t i = 0; i < impl_->links.size(); ++i)
    if (impl_->links[i]->request().set == set) impl_->links[i]->on_activate();
}

void Endpoint::deactivate(const std::string& set) { *impl_->set_flag(set) = false; }

void Endpoint::on_event(std::function<void(const CommsEvent&)> fn) { impl_->on_event = std::move(fn); }

bool Endpoint::active(const std::string& set) const {
  auto it = impl_->sets.find(set);
  return it != impl_->sets.end() && *it->second;
}

std::vector<LinkInfo> Endpoint::links() const {
  std::vector<LinkInfo> v;
  for (const auto& l : impl_->links) v.push_back(l->info());
  return v;
}

std::size_t Endpoint::accepted() const { return impl_->sessions.size(); }
std::uint64_t Endpoint::bytes_received() const { return impl_->bytes_received; }

}  // namespace dca
