#include <dca/testing/controller.h>

#include <cstring>
#include <stdexcept>
#include <utility>

#include <boost/asio/io_context.hpp>

#include <dca/package.h>
#include "host/port.h"
#include "host/timers.h"

// A package's entry point when the test links the package's objects (dca_add_controller_test); weak, so a test
// of types registered some other way links without one.
extern "C" __attribute__((weak)) const dca::PackageEntry* dca_package_entry_v1();

namespace dca::testing {
namespace {

// Adds the linked package's types to the registry, once per process.
void adopt_linked_package() {
  static const bool adopted = [] {
    if (dca_package_entry_v1 == nullptr) return true;
    const PackageEntry* e = dca_package_entry_v1();
    Registry staged;
    e->add_types(staged);
    std::string error;
    if (!Registry::global().adopt(std::move(staged), e->name, &error)) throw std::invalid_argument(error);
    return true;
  }();
  (void)adopted;
}

Bytes as_bytes(const char* data, std::size_t n) { return {reinterpret_cast<const std::byte*>(data), n}; }

std::string describe(const PortSpec& s) {
  if (s.type == PortType::Message) return s.message;
  std::string t(to_string(s.type));
  if (s.type == PortType::Vector) t += "[" + std::to_string(s.size) + "]";
  return t;
}

}  // namespace

double Ended::number() const {
  const auto oh = msgpack::unpack(value.data(), value.size());
  const auto& o = oh.get();
  if (o.type != msgpack::type::FLOAT64 && o.type != msgpack::type::FLOAT32 &&
      o.type != msgpack::type::POSITIVE_INTEGER && o.type != msgpack::type::NEGATIVE_INTEGER)
    throw std::runtime_error(done ? "the DONE value is not a number" : "the run ended ABORTED: " + reason);
  return o.as<double>();
}

std::string Ended::text() const {
  const auto oh = msgpack::unpack(value.data(), value.size());
  if (oh.get().type != msgpack::type::STR)
    throw std::runtime_error(done ? "the DONE value is not text" : "the run ended ABORTED: " + reason);
  return oh.get().as<std::string>();
}

struct ControllerUnderTest::Impl {
  boost::asio::io_context io;
  TimerServer timers{io, ClockKind::Simulated};
  std::unique_ptr<Controller> c;
  std::optional<Ended> ended;

  Input& input(std::string_view name) {
    Input* in = c->ports().find_input(name);
    if (in == nullptr) throw std::invalid_argument(c->ports().no_such_input(c->name(), name));
    return *in;
  }
  Output& output(std::string_view name) const {
    Output* out = c->ports().find_output(name);
    if (out == nullptr) throw std::invalid_argument(c->ports().no_such_output(c->name(), name));
    return *out;
  }
  std::invalid_argument wrong(const PortSpec& s, std::string_view what) const {
    return std::invalid_argument(c->name() + ": port '" + s.name + "' is " + describe(s) + ", not " +
                                 std::string(what));
  }
};

ControllerUnderTest::ControllerUnderTest(std::string_view type, std::vector<std::string> params, std::string path)
    : impl_(std::make_unique<Impl>()) {
  adopt_linked_package();
  impl_->c = Registry::global().create(type, {std::move(path), "local", std::move(params), &impl_->timers, nullptr});
  impl_->c->on_event = [this](const ComponentEvent& e) {
    impl_->ended = Ended{e.kind == ComponentEvent::Kind::Done, e.reason, e.value};
  };
}

ControllerUnderTest::~ControllerUnderTest() {
  if (impl_ && impl_->c) impl_->c->halt();
}

void ControllerUnderTest::configure() {
  std::string error;
  if (!impl_->c->configure(&error)) throw std::runtime_error(error);
}

void ControllerUnderTest::start() { start_bytes(nullptr, 0); }

void ControllerUnderTest::start_bytes(const char* data, std::size_t n) {
  impl_->ended.reset();
  std::string error;
  if (!impl_->c->start(as_bytes(data, n), &error)) throw std::runtime_error(error);
}

void ControllerUnderTest::halt() { impl_->c->halt(); }

std::string ControllerUnderTest::set_parameter(std::string_view name, const std::string& text) {
  std::string error;
  return impl_->c->set_parameter(name, text, &error) ? std::string() : error;
}

Controller::State ControllerUnderTest::state() const { return impl_->c->state(); }

const std::optional<Ended>& ControllerUnderTest::ended() const { return impl_->ended; }

void ControllerUnderTest::set(std::string_view input, double v) {
  Input& in = impl_->input(input);
  if (in.spec().type != PortType::Scalar) throw impl_->wrong(in.spec(), "scalar");
  in.deliver(as_bytes(reinterpret_cast<const char*>(&v), sizeof v));
}

void ControllerUnderTest::set(std::string_view input, const Eigen::VectorXd& v) {
  Input& in = impl_->input(input);
  const auto& s = in.spec();
  const auto n = static_cast<std::size_t>(v.size());
  if (s.type == PortType::Vector && s.size != n)
    throw impl_->wrong(s, "vector[" + std::to_string(n) + "]");
  if (s.type != PortType::Vector && s.type != PortType::VectorX) throw impl_->wrong(s, "a vector");
  in.deliver(as_bytes(reinterpret_cast<const char*>(v.data()), n * sizeof(double)));
}

void ControllerUnderTest::set_bytes(std::string_view input, const char* data, std::size_t n) {
  Input& in = impl_->input(input);
  if (in.spec().type != PortType::Value) throw impl_->wrong(in.spec(), "value");
  in.deliver(as_bytes(data, n));
}

void ControllerUnderTest::set_message_bytes(std::string_view input, std::string_view type,
                                            std::span<const std::byte> cdr) {
  Input& in = impl_->input(input);
  if (in.spec().type != PortType::Message || in.spec().message != type) throw impl_->wrong(in.spec(), type);
  in.deliver(cdr);
}

std::span<const std::byte> ControllerUnderTest::message_bytes(std::string_view output, std::string_view type) const {
  const Output& out = impl_->output(output);
  if (out.spec().type != PortType::Message || out.spec().message != type) throw impl_->wrong(out.spec(), type);
  return out.latest_bytes();
}

double ControllerUnderTest::get(std::string_view output) const {
  const Output& out = impl_->output(output);
  if (out.spec().type != PortType::Scalar) throw impl_->wrong(out.spec(), "scalar");
  if (!out.has_latest()) return 0.0;
  double v = 0;
  std::memcpy(&v, out.latest_bytes().data(), sizeof v);
  return v;
}

Eigen::VectorXd ControllerUnderTest::get_vector(std::string_view output) const {
  const Output& out = impl_->output(output);
  const auto& s = out.spec();
  if (s.type != PortType::Vector && s.type != PortType::VectorX) throw impl_->wrong(s, "a vector");
  if (!out.has_latest()) return Eigen::VectorXd::Zero(s.type == PortType::Vector ? s.size : 0);
  const Bytes b = out.latest_bytes();
  Eigen::VectorXd v(static_cast<Eigen::Index>(b.size() / sizeof(double)));
  std::memcpy(v.data(), b.data(), b.size());
  return v;
}

msgpack::object_handle ControllerUnderTest::get_value(std::string_view output) const {
  const Output& out = impl_->output(output);
  if (out.spec().type != PortType::Value) throw impl_->wrong(out.spec(), "value");
  if (!out.has_latest()) {
    static const char kNil = '\xc0';
    return msgpack::unpack(&kNil, 1);
  }
  const Bytes b = out.latest_bytes();
  return msgpack::unpack(reinterpret_cast<const char*>(b.data()), b.size());
}

std::uint64_t ControllerUnderTest::writes(std::string_view output) const {
  return impl_->output(output).stats().samples;
}

bool ControllerUnderTest::step(int n) {
  for (int i = 0; i < n; ++i)
    if (!impl_->timers.next_deadline()) return false;
    else impl_->timers.step();
  return true;
}

void ControllerUnderTest::advance(double seconds) {
  impl_->timers.advance_to(impl_->timers.now() + from_seconds(seconds));
}

double ControllerUnderTest::now() const { return to_seconds(impl_->timers.now()); }

std::uint64_t ControllerUnderTest::ticks() const { return impl_->c->ticks(); }

Controller& ControllerUnderTest::controller() { return *impl_->c; }

}  // namespace dca::testing
