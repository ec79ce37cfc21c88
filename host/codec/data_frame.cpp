#include "host/codec/data_frame.h"

#include <limits>
#include <utility>

#include "host/codec/wire.h"

namespace dca::data_frame {

namespace {

void put_u32(std::byte* p, std::uint32_t v) {
  p[0] = static_cast<std::byte>(v >> 24);
  p[1] = static_cast<std::byte>(v >> 16);
  p[2] = static_cast<std::byte>(v >> 8);
  p[3] = static_cast<std::byte>(v);
}

std::uint32_t get_u32(const std::byte* p) {
  return (std::to_integer<std::uint32_t>(p[0]) << 24) | (std::to_integer<std::uint32_t>(p[1]) << 16) |
         (std::to_integer<std::uint32_t>(p[2]) << 8) | std::to_integer<std::uint32_t>(p[3]);
}

// Sets *error (when given) and says Error.
Parse fail(std::string* error, std::string why) {
  if (error != nullptr) *error = std::move(why);
  return Parse::Error;
}

}  // namespace

void put_header(std::byte* h, Kind kind, std::uint32_t link, std::size_t body_size) {
  put_u32(h, static_cast<std::uint32_t>(body_size + kHeader - 4));
  h[4] = static_cast<std::byte>(kind);
  put_u32(h + 5, link);
}

Parse parse_frame(Bytes buf, Frame& f, std::size_t& used, std::string* error, std::uint32_t max_frame) {
  used = 0;
  if (buf.size() < 4) return Parse::NeedMore;
  const std::uint32_t len = get_u32(buf.data());
  if (len < kHeader - 4) return fail(error, "data frame of " + std::to_string(len) + " bytes has no kind and link");
  if (len > max_frame)
    return fail(error,
                "data frame of " + std::to_string(len) + " bytes exceeds the limit of " + std::to_string(max_frame));
  if (buf.size() < 4 + static_cast<std::size_t>(len)) {
    used = 4 + static_cast<std::size_t>(len);
    return Parse::NeedMore;
  }
  const auto k = std::to_integer<std::uint8_t>(buf[4]);
  if (k < 1 || k > kLastKind) return fail(error, "unknown data frame kind " + std::to_string(k));
  f.kind = static_cast<Kind>(k);
  f.link = get_u32(buf.data() + 5);
  f.body = buf.subspan(kHeader, len - (kHeader - 4));
  used = 4 + static_cast<std::size_t>(len);
  return Parse::Ok;
}

std::string encode_auth(const wire::Message& m) {
  const std::string frame = wire::encode(m);
  return frame.size() > wire::kHeaderSize ? frame.substr(wire::kHeaderSize) : std::string();
}

bool decode_auth(Bytes body, wire::Message& m, std::string* error) {
  auto d = wire::decode_body({reinterpret_cast<const char*>(body.data()), body.size()});
  if (d.status != wire::Decoded::Status::kMessage) {
    if (error != nullptr) *error = "malformed handshake message: " + d.error;
    return false;
  }
  m = std::move(d.message);
  return true;
}

std::string encode_hello(const Hello& h) {
  const auto& r = h.request;
  auto v = wire::Value::map()
                     .set("from", r.from)
                     .set("out", r.out)
                     .set("to", r.to)
                     .set("in", r.in)
                     .set("set", r.set)
                     .set("mode", to_string(r.mode))
                     .set("queue", static_cast<std::int64_t>(r.queue))
                     .set("type", to_string(h.out.type))
                     .set("size", static_cast<std::int64_t>(h.out.size));
  if (r.stamped) v.set("stamped", true);
  if (h.out.type == PortType::Message) v.set("message", h.out.message);  // its type's ROS name
  if (h.sender != 0) {
    v.set("sender", static_cast<std::int64_t>(h.sender & kMaxSerial));
    v.set("serial", static_cast<std::int64_t>(h.serial & kMaxSerial));
  }
  std::string out;
  wire::encode_value(v, out);
  return out;
}

namespace {

// The string fields of a Hello, by key.
std::string* string_field(const std::string& key, Hello& h, std::string& mode, std::string& type) {
  if (key == "from") return &h.request.from;
  if (key == "out") return &h.request.out;
  if (key == "to") return &h.request.to;
  if (key == "in") return &h.request.in;
  if (key == "set") return &h.request.set;
  if (key == "mode") return &mode;
  if (key == "type") return &type;
  if (key == "message") return &h.out.message;
  return nullptr;
}

// The unsigned 32-bit fields of a Hello, by key.
std::uint32_t* count_field(const std::string& key, Hello& h) {
  if (key == "queue") return &h.request.queue;
  if (key == "size") return &h.out.size;
  return nullptr;
}

// The largest value the count field `key` may hold.
std::int64_t count_limit(const std::string& key) { return key == "queue" ? kMaxQueue : kMaxSize; }

// "" or why `s` cannot be a name: longer than `max` or holding a control character.
std::string name_problem(const std::string& key, const std::string& s, std::size_t max) {
  if (s.size() > max)
    return "hello: '" + key + "' is " + std::to_string(s.size()) + " bytes (at most " + std::to_string(max) + ")";
  for (unsigned char c : s)
    if (c < 0x20 || c == 0x7f) return "hello: '" + key + "' holds a control character";
  return "";
}

// Sets the field `key` of `h` (unknown keys are ignored): "" or why the value does not fit.
std::string set_field(const std::string& key, const wire::Value& val, Hello& h, std::string& mode, std::string& type) {
  if (auto* s = string_field(key, h, mode, type)) {
    if (!val.is_string()) return "hello: '" + key + "' is not a string";
    if (auto why = name_problem(key, val.as_string(), kMaxName); !why.empty()) return why;
    *s = val.as_string();
  } else if (auto* n = count_field(key, h)) {
    if (!val.is_int() || val.as_int() < 0) return "hello: '" + key + "' is not a count";
    if (val.as_int() > count_limit(key))
      return "hello: '" + key + "' is " + std::to_string(val.as_int()) + " (at most " +
             std::to_string(count_limit(key)) + ")";
    *n = static_cast<std::uint32_t>(val.as_int());
  }
  return "";
}

// Decodes the map `v` into `h`: "" or why not.
std::string decode_map(const wire::Value& v, Hello& h) {
  if (!v.is_map()) return "hello is not a map";
  std::string mode = "push", type;
  bool have_type = false;
  for (const auto& [key, val] : v.as_map()) {
    if (!key.is_string()) continue;
    have_type = have_type || key.as_string() == "type";
    if (key.as_string() == "sender" || key.as_string() == "serial") {
      if (!val.is_int() || val.as_int() < 0) return "hello: '" + key.as_string() + "' is not a count";
      (key.as_string() == "sender" ? h.sender : h.serial) = static_cast<std::uint64_t>(val.as_int());
      continue;
    }
    if (key.as_string() == "stamped") {
      if (!val.is_bool()) return "hello: 'stamped' is not a boolean";
      h.request.stamped = val.as_bool();
      continue;
    }
    if (auto why = set_field(key.as_string(), val, h, mode, type); !why.empty()) return why;
  }
  const auto m = mode_from(mode);
  const auto t = port_type_from(type);
  if (!m) return "hello: unknown mode '" + mode + "'";
  if (!have_type || !t) return "hello: unknown port type '" + type + "'";
  if (h.request.to.empty() || h.request.in.empty()) return "hello: no destination named";
  h.request.mode = *m;
  h.out.type = *t;
  h.out.name = h.request.out;
  return "";
}

}  // namespace

bool decode_hello(Bytes body, Hello& h, std::string* error) {
  wire::Value v;
  std::string why;
  if (!wire::decode_value({reinterpret_cast<const char*>(body.data()), body.size()}, v, &why))
    why = "malformed hello: " + why;
  else
    why = decode_map(v, h);
  if (why.empty()) return true;
  if (error != nullptr) *error = std::move(why);
  return false;
}

std::string encode_peer(const Location& l) {
  std::string out;
  wire::encode_value(wire::Value::map().set("host", l.host).set("uds", l.data_uds).set("tcp", l.data_tcp), out);
  return out;
}

bool decode_peer(Bytes body, Location& l, std::string* error) {
  wire::Value v;
  std::string why;
  if (!wire::decode_value({reinterpret_cast<const char*>(body.data()), body.size()}, v, &why)) {
    why = "malformed peer introduction: " + why;
  } else if (!v.is_map()) {
    why = "peer introduction is not a map";
  } else {
    for (const auto& [key, val] : v.as_map()) {
      if (!key.is_string()) continue;
      const auto& k = key.as_string();
      std::string* field = k == "host" ? &l.host : k == "uds" ? &l.data_uds : k == "tcp" ? &l.data_tcp : nullptr;
      if (field == nullptr) continue;
      if (!val.is_string()) why = "peer: '" + k + "' is not a string";
      else if (val.as_string().size() > kMaxAddress) why = "peer: '" + k + "' is too long";
      else if (!name_problem(k, val.as_string(), kMaxAddress).empty()) why = "peer: '" + k + "' holds a control character";
      if (!why.empty()) break;
      *field = val.as_string();
    }
  }
  if (why.empty()) return true;
  if (error != nullptr) *error = std::move(why);
  return false;
}

}  // namespace dca::data_frame
