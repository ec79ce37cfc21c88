#include "host/codec/wire.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <msgpack.hpp>

#include "host/codec/hex.h"
#include "host/codec/msgpack_number.h"

namespace dca::wire {
namespace {

const std::string kEmptyString;
const Value::Array kEmptyArray;
const Value::Map kEmptyMap;
const Value kNil;

// A msgpack output stream appending to a std::string.
struct StringStream {
  std::string& out;
  void write(const char* p, std::size_t n) { out.append(p, n); }
};

bool pack(msgpack::packer<StringStream>& pk, const Value& v, int depth) {
  if ((v.is_array() || v.is_map()) && depth > kMaxDepth) return false;
  if (v.is_nil()) {
    pk.pack_nil();
  } else if (v.is_bool()) {
    v.as_bool() ? pk.pack_true() : pk.pack_false();
  } else if (v.is_int()) {
    pk.pack_int64(v.as_int());
  } else if (v.is_float()) {
    pack_real(pk, v.as_float());
  } else if (v.is_string()) {
    const auto& s = v.as_string();
    pk.pack_str(static_cast<uint32_t>(s.size()));
    pk.pack_str_body(s.data(), static_cast<uint32_t>(s.size()));
  } else if (v.is_array()) {
    const auto& a = v.as_array();
    pk.pack_array(static_cast<uint32_t>(a.size()));
    for (const auto& e : a)
      if (!pack(pk, e, depth + 1)) return false;
  } else {
    const auto& m = v.as_map();
    pk.pack_map(static_cast<uint32_t>(m.size()));
    for (const auto& [k, e] : m)
      if (!pack(pk, k, depth + 1) || !pack(pk, e, depth + 1)) return false;
  }
  return true;
}

// msgpack object -> Value; false with *error for what dca does not carry (ext). An integer above INT64_MAX is
// carried as the nearest double.
bool convert(const msgpack::object& o, Value& out, int depth, std::string* error) {
  if ((o.type == msgpack::type::ARRAY || o.type == msgpack::type::MAP) && depth > kMaxDepth) {
    *error = "values nested deeper than " + std::to_string(kMaxDepth);
    return false;
  }
  switch (o.type) {
    case msgpack::type::NIL:
      out = Value();
      return true;
    case msgpack::type::BOOLEAN:
      out = Value(o.via.boolean);
      return true;
    case msgpack::type::POSITIVE_INTEGER:
      // above INT64_MAX: the nearest double (another encoder's whole double, or a uint64 field)
      if (o.via.u64 > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()))
        out = Value(static_cast<double>(o.via.u64));
      else
        out = Value(static_cast<std::int64_t>(o.via.u64));
      return true;
    case msgpack::type::NEGATIVE_INTEGER:
      out = Value(o.via.i64);
      return true;
    case msgpack::type::FLOAT32:
    case msgpack::type::FLOAT64:
      out = Value(o.via.f64);
      return true;
    case msgpack::type::STR:
      out = Value(std::string(o.via.str.ptr, o.via.str.size));
      return true;
    case msgpack::type::BIN:
      out = Value(std::string(o.via.bin.ptr, o.via.bin.size));
      return true;
    case msgpack::type::ARRAY: {
      Value::Array a(o.via.array.size);
      for (uint32_t i = 0; i < o.via.array.size; ++i)
        if (!convert(o.via.array.ptr[i], a[i], depth + 1, error)) return false;
      out = Value(std::move(a));
      return true;
    }
    case msgpack::type::MAP: {
      Value::Map m(o.via.map.size);
      for (uint32_t i = 0; i < o.via.map.size; ++i) {
        if (!convert(o.via.map.ptr[i].key, m[i].first, depth + 1, error) ||
            !convert(o.via.map.ptr[i].val, m[i].second, depth + 1, error))
          return false;
      }
      out = Value(std::move(m));
      return true;
    }
    case msgpack::type::EXT:
      *error = "msgpack ext values are not supported";
      return false;
  }
  *error = "unknown msgpack type";
  return false;
}

bool reference_everything(msgpack::type::object_type, std::size_t, void*) { return true; }

Decoded fail(std::string reason) {
  Decoded d;
  d.status = Decoded::Status::kError;
  d.error = std::move(reason);
  return d;
}

// Unpacks exactly one msgpack object from `bytes` into `oh`. Limits bound the work hostile input can cause: no
// container can claim more elements than it has bytes, nesting stops at kMaxDepth. False with *error naming
// `what` ("message body", "value") when `bytes` is empty, truncated, malformed or has trailing bytes.
bool unpack_one(std::string_view bytes, const std::string& what, msgpack::object_handle& oh, std::string* error) {
  const auto failed = [&](std::string why) {
    *error = std::move(why);
    return false;
  };
  if (bytes.empty()) return failed("empty " + what);
  std::size_t off = 0;
  const msgpack::unpack_limit limit(bytes.size(), bytes.size() / 2 + 1, bytes.size(), bytes.size(), 0,
                                    static_cast<std::size_t>(kMaxDepth) + 1);
  try {
    oh = msgpack::unpack(bytes.data(), bytes.size(), off, reference_everything, nullptr, limit);
  } catch (const msgpack::insufficient_bytes&) {
    return failed("truncated " + what + " (" + std::to_string(bytes.size()) + " bytes)");
  } catch (const std::exception& e) {
    const std::string kind = what.substr(what.rfind(' ') + 1);  // "body", "value"
    return failed("malformed msgpack " + kind + ": " + e.what());
  }
  if (off != bytes.size()) return failed(std::to_string(bytes.size() - off) + " trailing bytes after the " + what);
  return true;
}

void render(const Value& v, std::string& out, int depth) {
  if (depth > kMaxDepth) {
    out += "...";
    return;
  }
  if (v.is_nil()) {
    out += "nil";
  } else if (v.is_bool()) {
    out += v.as_bool() ? "true" : "false";
  } else if (v.is_int()) {
    out += std::to_string(v.as_int());
  } else if (v.is_float()) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.17g", v.as_float());
    out += buf;
  } else if (v.is_string()) {
    out += '"';
    for (unsigned char c : v.as_string()) {
      if (c == '"' || c == '\\') {
        out += '\\';
        out += static_cast<char>(c);
      } else if (c < 0x20 || c >= 0x7f) {
        out += "\\x" + hex::encode(std::string_view(reinterpret_cast<const char*>(&c), 1));
      } else {
        out += static_cast<char>(c);
      }
    }
    out += '"';
  } else if (v.is_array()) {
    out += '[';
    bool first = true;
    for (const auto& e : v.as_array()) {
      if (!first) out += ", ";
      first = false;
      render(e, out, depth + 1);
    }
    out += ']';
  } else {
    out += '{';
    bool first = true;
    for (const auto& [k, e] : v.as_map()) {
      if (!first) out += ", ";
      first = false;
      if (k.is_string()) {
        out += k.as_string();
      } else {
        out += '[';
        render(k, out, depth + 1);
        out += ']';
      }
      out += " = ";
      render(e, out, depth + 1);
    }
    out += '}';
  }
}

}  // namespace

std::int64_t Value::as_int(std::int64_t fallback) const {
  if (is_int()) return std::get<std::int64_t>(v_);
  if (is_float()) {
    const double d = std::get<double>(v_);
    if (std::isfinite(d) && d >= -9.2e18 && d <= 9.2e18) return static_cast<std::int64_t>(d);
  }
  return fallback;
}

double Value::as_float(double fallback) const {
  if (is_float()) return std::get<double>(v_);
  if (is_int()) return static_cast<double>(std::get<std::int64_t>(v_));
  return fallback;
}

const std::string& Value::as_string() const { return is_string() ? std::get<std::string>(v_) : kEmptyString; }
const Value::Array& Value::as_array() const { return is_array() ? std::get<Array>(v_) : kEmptyArray; }
const Value::Map& Value::as_map() const { return is_map() ? std::get<Map>(v_) : kEmptyMap; }

Value::Array& Value::array_ref() {
  if (!is_array()) v_ = Array{};
  return std::get<Array>(v_);
}

Value::Map& Value::map_ref() {
  if (!is_map()) v_ = Map{};
  return std::get<Map>(v_);
}

const Value* Value::find(std::string_view key) const {
  if (!is_map()) return nullptr;
  for (const auto& [k, v] : std::get<Map>(v_))
    if (k.is_string() && k.as_string() == key) return &v;
  return nullptr;
}

const Value& Value::operator[](std::string_view key) const {
  const Value* v = find(key);
  return v != nullptr ? *v : kNil;
}

Value& Value::set(std::string_view key, Value v) {
  auto& m = map_ref();
  for (auto& [k, e] : m) {
    if (k.is_string() && k.as_string() == key) {
      e = std::move(v);
      return *this;
    }
  }
  m.emplace_back(Value(key), std::move(v));
  return *this;
}

std::string Value::str() const {
  std::string out;
  render(*this, out, 0);
  return out;
}

Message make_reply(const Message& request, Value payload) {
  if (!payload.is_map()) payload = Value::map();
  return Message{"ok", request.id, std::move(payload)};
}

Message make_error(const Message& request, std::string_view reason) {
  return Message{"error", request.id, Value::map().set("reason", Value(reason))};
}

bool encode(const Message& m, std::string& out, std::string* error) {
  const std::size_t start = out.size();
  out.append(kHeaderSize, '\0');
  StringStream s{out};
  msgpack::packer<StringStream> pk(s);
  pk.pack_array(3);
  pk.pack_str(static_cast<uint32_t>(m.type.size()));
  pk.pack_str_body(m.type.data(), static_cast<uint32_t>(m.type.size()));
  pk.pack_uint64(m.id);
  bool ok = true;
  if (m.payload.is_map()) {
    ok = pack(pk, m.payload, 1);
  } else {
    pk.pack_map(0);
  }
  const std::size_t body = out.size() - start - kHeaderSize;
  if (!ok || body > 0xffffffffu) {
    out.resize(start);
    if (error != nullptr) *error = ok ? "message body larger than 4 GiB" : "values nested deeper than 64";
    return false;
  }
  out[start + 0] = static_cast<char>((body >> 24) & 0xff);
  out[start + 1] = static_cast<char>((body >> 16) & 0xff);
  out[start + 2] = static_cast<char>((body >> 8) & 0xff);
  out[start + 3] = static_cast<char>(body & 0xff);
  return true;
}

std::string encode(const Message& m) {
  std::string out;
  encode(m, out);
  return out;
}

void encode_value(const Value& v, std::string& out) {
  StringStream s{out};
  msgpack::packer<StringStream> pk(s);
  if (!pack(pk, v, 0)) pk.pack_nil();
}

Decoded decode_body(std::string_view body) {
  msgpack::object_handle oh;
  std::string why;
  if (!unpack_one(body, "message body", oh, &why)) return fail(why);
  const msgpack::object& o = oh.get();
  if (o.type != msgpack::type::ARRAY || o.via.array.size != 3)
    return fail("message body is not an array [type, id, payload]");
  const msgpack::object* f = o.via.array.ptr;
  if (f[0].type != msgpack::type::STR || f[0].via.str.size == 0 || f[0].via.str.size > 64)
    return fail("message type is not a string of 1 to 64 bytes");
  if (f[1].type != msgpack::type::POSITIVE_INTEGER) return fail("message id is not an unsigned integer");
  if (f[2].type != msgpack::type::MAP) return fail("message payload is not a map");
  Decoded d;
  d.message.type.assign(f[0].via.str.ptr, f[0].via.str.size);
  d.message.id = f[1].via.u64;
  std::string error;
  if (!convert(f[2], d.message.payload, 1, &error)) return fail("message payload: " + error);
  d.status = Decoded::Status::kMessage;
  d.consumed = body.size();
  return d;
}

bool decode_value(std::string_view bytes, Value& out, std::string* error) {
  msgpack::object_handle oh;
  std::string why;
  if (unpack_one(bytes, "value", oh, &why) && convert(oh.get(), out, 0, &why)) return true;
  if (error != nullptr) *error = std::move(why);
  return false;
}

Decoded decode_frame(std::string_view bytes, std::size_t max_frame) {
  if (bytes.size() < kHeaderSize) return Decoded{};
  const auto b = [&](std::size_t i) { return static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[i])); };
  const std::size_t len = (b(0) << 24) | (b(1) << 16) | (b(2) << 8) | b(3);
  if (len > max_frame)
    return fail("frame of " + std::to_string(len) + " bytes exceeds the limit of " + std::to_string(max_frame));
  if (len == 0) return fail("empty frame");
  if (bytes.size() < kHeaderSize + len) return Decoded{};
  Decoded d = decode_body(bytes.substr(kHeaderSize, len));
  if (d.status == Decoded::Status::kMessage) d.consumed = kHeaderSize + len;
  return d;
}

}  // namespace dca::wire
