#include "host/port.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "host/codec/msgpack_number.h"

namespace dca {

// ---------------------------------------------------------------------------------------------- names ---

std::string_view to_string(PortType t) {
  switch (t) {
    case PortType::Scalar: return "scalar";
    case PortType::Vector: return "vector";
    case PortType::VectorX: return "vectorx";
    case PortType::Value: return "value";
    case PortType::Message: return "message";
  }
  return "?";
}

std::optional<PortType> port_type_from(std::string_view s) {
  for (auto t : {PortType::Scalar, PortType::Vector, PortType::VectorX, PortType::Value, PortType::Message})
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
PortSpec message_port(std::string name, std::string message, std::string units) {
  PortSpec s{std::move(name), PortType::Message, 0, std::move(units), {}};
  s.message = std::move(message);
  return s;
}

std::string describe_type(const PortSpec& s) {
  if (s.type == PortType::Message) return s.message.empty() ? "message" : s.message;
  std::string d(to_string(s.type));
  if (s.type == PortType::Vector) {  // (not "[" + to_string(...): GCC 12 -O3 warns -Wrestrict on it)
    d += '[';
    d += std::to_string(s.size);
    d += ']';
  }
  return d;
}

// Numeric ports carry doubles: a scalar is one, a vector[N] N, a vectorx any number. A vectorx end takes the
// other end's size; two fixed sizes must be equal (so a scalar and a vector[1] connect). A sample that does not
// fit the input is refused there and counted (Port::accepts). Values connect to values only, messages to messages
// of the same type (its CDR is checked as it arrives: docs/data-plane.md, "Typed messages"). dca check holds
// the sizes it can work out to the same rules before anything starts (docs/data-plane.md, "Port types").
std::string compatibility_error(const PortSpec& out, const PortSpec& in) {
  const auto fixed = [](const PortSpec& p) { return p.type == PortType::Scalar || p.type == PortType::Vector; };
  const auto size = [](const PortSpec& p) { return p.type == PortType::Scalar ? 1u : p.size; };
  bool ok = false;
  if (out.type == PortType::Message || in.type == PortType::Message) ok = out.type == in.type && out.message == in.message;
  else if (out.type == PortType::Value || in.type == PortType::Value) ok = out.type == in.type;
  else ok = !fixed(out) || !fixed(in) || size(out) == size(in);
  if (ok) return "";
  return "output '" + out.name + "' is " + describe_type(out) + " but input '" + in.name + "' is " + describe_type(in);
}

bool is_tap_input(const PortSpec& in) { return in.type == PortType::Value && in.name.rfind("tap:", 0) == 0; }

Transport choose_transport(std::string_view my_host, bool dest_local, const Location& dest) {
  if (dest_local) return Transport::InProcess;
  if (dest.host == my_host && !dest.data_uds.empty()) return Transport::Unix;
  return Transport::Tcp;
}

// ---------------------------------------------------------------------------------------------- ports ---

Port::Port(PortSpec spec) : spec_(std::move(spec)) {
  if (spec_.type == PortType::Scalar) spec_.size = 1;
  if (spec_.type != PortType::Scalar && spec_.type != PortType::Vector) spec_.size = 0;
  if (spec_.type == PortType::Message) {
    message_ = msgs::find_type(spec_.message);
    if (!message_) throw std::invalid_argument("port '" + spec_.name + "': no message type '" + spec_.message + "'");
    latest_.resize(message_->max_size);  // its samples never allocate
    return;
  }
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
    case PortType::Message: ok = message_->valid(b); break;
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
    wire::pack_real(pk, n ? at(0) : 0.0);
    return;
  }
  pk.pack_array(static_cast<std::uint32_t>(n));
  for (std::size_t i = 0; i < n; ++i) wire::pack_real(pk, at(i));
}
}  // namespace

void Port::pack_latest(msgpack::packer<msgpack::sbuffer>& pk) const {
  if (message_ && has_latest_) return message_->pack(latest_bytes(), pk);
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
void Input::remove_feeder(InputFeeder* f) {
  std::erase(feeders_, f);
  if (hold_ && hold_->holder == f) hold_->holder = nullptr;  // its writer is gone: the next may take it at once
}

void Input::set_exclusive(std::uint32_t max_lease_ticks) {
  hold_.reset();
  owns_hold_ = max_lease_ticks > 0;
  if (owns_hold_) hold_ = std::make_shared<Hold>(Hold{max_lease_ticks});
}

void Input::share_exclusive(Input& other) {
  hold_ = other.hold_;
  owns_hold_ = false;
}

void Input::deliver_from(InputFeeder* from, Bytes b) {
  if (hold_ && from != nullptr) {
    if (std::find(feeders_.begin(), feeders_.end(), from) == feeders_.end()) {
      ++refused_;  // a sample held for a connection that has closed since: its writer is gone
      return;
    }
    Hold& h = *hold_;
    const std::uint64_t lease = std::clamp<std::uint64_t>(h.interval, 1, h.max_lease);
    if (h.holder != nullptr && h.holder != from && h.ticks - h.held_at < lease) {
      ++refused_;
      if (on_refused) on_refused(from->writer(), h.holder->writer());
      return;
    }
    if (h.holder != from) h.interval = 0;
    else if (h.ticks > h.held_at) h.interval = h.ticks - h.held_at;
    h.holder = from;
    h.held_at = h.ticks;
  }
  deliver(b);
}

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
  unread_ = true;
  if (on_sample) on_sample();
}

void Input::make_current(const std::vector<std::byte>& b, std::size_t n) {
  if (current_.size() < n) current_.resize(n);
  if (n) std::memcpy(current_.data(), b.data(), n);
  current_size_ = n;
  has_current_ = true;
  unread_ = true;
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
  take_queued();
  return true;
}
// Out of line: a read that finds nothing new stays a few instructions (tests/bench/port_read_bench.cpp).
[[gnu::noinline]] void Input::take_queued() {
  const std::size_t last = (head_ + count_ - 1) % slots_.size();
  make_current(slots_[last], sizes_[last]);
  head_ = 0;
  count_ = 0;
}

Read Input::take_for_read() {
  if (count_ != 0) take_queued();
  if (!has_current()) return Read::None;
  if (!unread_) return Read::Old;
  unread_ = false;
  return Read::New;
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
  // FNV-1a over 64-bit words (the tail by bytes): an eighth of the multiplies of a byte-wise FNV
  constexpr std::uint64_t kPrime = 1099511628211ull;
  std::size_t at = 0;
  for (; at + 8 <= b.size(); at += 8) {
    std::uint64_t w;
    std::memcpy(&w, b.data() + at, 8);
    digest_ = (digest_ ^ w) * kPrime;
  }
  for (; at < b.size(); ++at) digest_ = (digest_ ^ static_cast<std::uint64_t>(b[at])) * kPrime;
  set_latest(b);
  for (std::size_t i = 0; i < links_.size(); ++i) links_[i]->on_write(b);
  return true;
}

// ------------------------------------------------------------------- a controller's reads and writes ---
// (dca/port.h: In<T>, Out<T>): one call each, resolved in the dca process by a package's code.

namespace port_detail {

Read read(Input& in, double& x) {
  const Read r = in.take_for_read();
  if (r != Read::None) x = in.scalar();
  return r;
}

Read read(Input& in, double* x, std::size_t n) {
  const Read r = in.take_for_read();
  const Bytes b = in.current_bytes();
  if (r == Read::None || b.size() != n * sizeof(double)) return Read::None;
  std::memcpy(x, b.data(), b.size());
  return r;
}

Read read(Input& in, Eigen::VectorXd& x) {
  const Read r = in.take_for_read();
  if (r == Read::None) return r;
  const auto v = in.vector();
  if (x.size() != v.size()) x.resize(v.size());
  x = v;
  return r;
}

Read read(Input& in, PortValue& x) {
  const Read r = in.take_for_read();
  if (r != Read::None) x = in.value();
  return r;
}

bool pop(Input& in, double& x) {
  if (!in.pop()) return false;
  in.mark_read();
  x = in.scalar();
  return true;
}

bool write(Output& out, double v) { return out.write(v); }

bool write(Output& out, const double* v, std::size_t n) {
  return out.write(Eigen::Map<const Eigen::VectorXd>(v, static_cast<Eigen::Index>(n)));
}

bool write_bytes(Output& out, const char* data, std::size_t n) {
  return out.write_bytes({reinterpret_cast<const std::byte*>(data), n});
}

Read read_bytes(Input& in, Bytes& x) {
  const Read r = in.take_for_read();
  if (r != Read::None) x = in.current_bytes();
  return r;
}

}  // namespace port_detail

std::string link_key(const ConnectRequest& r) {
  return r.from + "|" + r.out + ">" + r.to + "|" + r.in + "@" + r.set;
}

void LinkGate::deliver(Input& in, Bytes b, InputFeeder* from) {
  if (owner_ != nullptr && from != nullptr && from != owner_) {
    ++stale_;  // the replaced connection's: it goes with its process (docs/time.md, "A restart" 11)
    return;
  }
  ++received_;
  from_ = from;
  if (!gated || (held_head_ == held_.size() && delivered_ < allowed_)) {
    ++delivered_;
    return in.deliver_from(from, b);
  }
  held_.emplace_back(b.begin(), b.end());
}

bool LinkGate::release(Input* in, std::uint64_t n) {
  allowed_ = n;
  while (delivered_ < allowed_ && held_head_ < held_.size()) {
    ++delivered_;
    auto& h = held_[held_head_++];
    if (in) in->deliver_from(from_, {h.data(), h.size()});
  }
  if (held_head_ == held_.size()) {
    held_.clear();
    held_head_ = 0;
  }
  return received_ >= n;
}

void LinkGate::reset() {
  received_ = delivered_ = allowed_ = 0;
  held_.clear();
  held_head_ = 0;
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

}  // namespace dca
