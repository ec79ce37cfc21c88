#include "host/net/tap.h"

#include <boost/asio/post.hpp>

#include <cstring>
#include <stdexcept>

#include "host/codec/json.h"

namespace dca::tap {

std::string input_name(const std::string& path) { return "tap:" + path; }

std::string topic_of(const std::string& path) {
  std::string t = "/" + path;
  for (char& c : t)
    if (c == '.') c = '/';
  return t;
}

bool unstamp(Bytes stamped, std::int64_t& t, Bytes& sample) {
  if (stamped.size() < sizeof t) return false;
  std::memcpy(&t, stamped.data(), sizeof t);
  sample = stamped.subspan(sizeof t);
  return true;
}

namespace {

// A msgpack object as JSON: maps' keys as strings (others as their JSON text), binary and extensions as null,
// nesting deeper than 32 as null.
void put_object(std::string& out, const msgpack::object& o, int depth) {
  if (depth > 32) {
    out += "null";
    return;
  }
  switch (o.type) {
    case msgpack::type::BOOLEAN: out += o.via.boolean ? "true" : "false"; return;
    case msgpack::type::POSITIVE_INTEGER: out += std::to_string(o.via.u64); return;
    case msgpack::type::NEGATIVE_INTEGER: out += std::to_string(o.via.i64); return;
    case msgpack::type::FLOAT32:
    case msgpack::type::FLOAT64: json::append_number(out, o.via.f64); return;
    case msgpack::type::STR: json::append_string(out, {o.via.str.ptr, o.via.str.size}); return;
    case msgpack::type::ARRAY:
      out += '[';
      for (std::uint32_t i = 0; i < o.via.array.size; ++i) {
        if (i) out += ',';
        put_object(out, o.via.array.ptr[i], depth + 1);
      }
      out += ']';
      return;
    case msgpack::type::MAP:
      out += '{';
      for (std::uint32_t i = 0; i < o.via.map.size; ++i) {
        if (i) out += ',';
        const auto& kv = o.via.map.ptr[i];
        if (kv.key.type == msgpack::type::STR) {
          json::append_string(out, {kv.key.via.str.ptr, kv.key.via.str.size});
        } else {
          std::string k;
          put_object(k, kv.key, depth + 1);
          json::append_string(out, k);
        }
        out += ':';
        put_object(out, kv.val, depth + 1);
      }
      out += '}';
      return;
    default: out += "null"; return;
  }
}

double at(Bytes b, std::size_t i) {
  double d;
  std::memcpy(&d, b.data() + i * sizeof d, sizeof d);
  return d;
}

}  // namespace

bool sample_values(const PortSpec& spec, Bytes sample, std::vector<double>& out) {
  out.clear();
  if (spec.type == PortType::Value || spec.type == PortType::Message || sample.size() % sizeof(double) != 0)
    return false;
  if (spec.type == PortType::Scalar && sample.size() != sizeof(double)) return false;
  if (spec.type == PortType::Vector && sample.size() != spec.size * sizeof(double)) return false;
  for (std::size_t i = 0; i < sample.size() / sizeof(double); ++i) out.push_back(at(sample, i));
  return true;
}

std::string sample_json(const PortSpec& spec, Bytes sample) {
  std::string out = "{\"value\":";
  std::vector<double> v;
  if (spec.type == PortType::Message) {
    const auto* m = msgs::find_type(spec.message);
    out += m ? m->json(sample) : "null";
  } else if (spec.type == PortType::Value) {
    try {
      auto oh = msgpack::unpack(reinterpret_cast<const char*>(sample.data()), sample.size());
      put_object(out, oh.get(), 0);
    } catch (const std::exception&) {
      out += "null";
    }
  } else if (!sample_values(spec, sample, v)) {
    out += "null";
  } else if (spec.type == PortType::Scalar) {
    json::append_number(out, v[0]);
  } else {
    json::append_numbers(out, v);
  }
  return out + "}";
}

std::string json_schema(const std::string& title, const PortSpec& spec) {
  std::string s = "{\"type\":\"object\",\"title\":";
  json::append_string(s, title);
  s += ",\"properties\":{\"value\":";
  std::string num = R"({"type":"number")";
  if (!spec.units.empty()) {
    num += ",\"description\":";
    json::append_string(num, spec.units);
  }
  num += "}";
  switch (spec.type) {
    case PortType::Scalar: s += num; break;
    case PortType::Vector:
      s += R"({"type":"array","items":)" + num + ",\"minItems\":" + std::to_string(spec.size) +
           ",\"maxItems\":" + std::to_string(spec.size) + "}";
      break;
    case PortType::VectorX: s += R"({"type":"array","items":)" + num + "}"; break;
    case PortType::Value: s += "{}"; break;
    case PortType::Message: {
      const auto* m = msgs::find_type(spec.message);
      s += m ? m->json_schema() : "{}";
      break;
    }
  }
  return s + "}}";
}

// ------------------------------------------------------------------------------------------------ Taps ---

Taps::Tap* Taps::add(const std::string& path, const PortSpec& spec, std::size_t queue, std::string* error) {
  if (Tap* t = find(path)) {
    t->input->reserve_queue(queue);
    return t;
  }
  if (path.empty()) {
    *error = "a tap needs the path of an output";
    return nullptr;
  }
  if (spec.type == PortType::Vector && spec.size == 0) {
    *error = "tap " + path + ": a vector port needs its size";
    return nullptr;
  }
  if (spec.type == PortType::Message && !msgs::find_type(spec.message)) {
    *error = "tap " + path + ": no message type '" + spec.message + "'";
    return nullptr;
  }
  auto t = std::make_unique<Tap>();
  t->path = path;
  t->spec = spec;
  try {
    t->input = &ports_->add_input(value_port(input_name(path)), std::max<std::size_t>(queue, 1));
  } catch (const std::exception& e) {
    *error = "tap " + path + ": " + e.what();
    return nullptr;
  }
  taps_.push_back(std::move(t));
  return taps_.back().get();
}

Taps::Tap* Taps::find(const std::string& path) const {
  for (const auto& t : taps_)
    if (t->path == path) return t.get();
  return nullptr;
}

void Taps::drain(const Sink& sink) {
  for (const auto& t : taps_) {
    while (t->input->pop()) {
      std::int64_t time = 0;
      Bytes sample;
      if (!unstamp(t->input->current_bytes(), time, sample)) {
        ++t->malformed;
        continue;
      }
      ++t->taken;
      if (sink) sink(*t, time, sample);
    }
  }
}

// -------------------------------------------------------------------------------------------- TapPoint ---

TapPoint::TapPoint(boost::asio::io_context& io, const std::string& host, std::string name, EndpointOptions options,
                   const std::string& uds_path, const std::string& tcp_address)
    : io_(io), name_(std::move(name)), endpoint_(io, host, std::move(options)) {
  endpoint_.listen(uds_path, tcp_address);
  endpoint_.add_component(name_, ports_);
}

TapPoint::~TapPoint() { endpoint_.remove_component(name_); }

Taps::Tap* TapPoint::add(const std::string& path, const PortSpec& spec, std::size_t queue, std::string* error) {
  Taps::Tap* t = taps_.add(path, spec, queue, error);
  if (t) t->input->on_sample = [this] { schedule(); };
  return t;
}

// One drain per burst of samples, from the loop: until then the tap inputs' queues bound what waits.
void TapPoint::schedule() {
  if (posted_) return;
  posted_ = true;
  boost::asio::post(io_, [this, alive = std::weak_ptr<bool>(alive_)] {
    if (alive.expired()) return;
    posted_ = false;
    taps_.drain(on_sample);
  });
}

}  // namespace dca::tap
