#pragma once
// host/codec: pure encoders and decoders. No Asio, no Beast, no socket, nothing of host/net or host/web.
// The control plane's wire format (docs/control-plane.md). Pure code: no I/O.
//
// A frame is a 4-byte big-endian length, then a msgpack body: the array [type, id, payload] where `type` is a
// non-empty string ("spawn", "ok", ...), `id` an unsigned request id (0 for events) and `payload` a msgpack map.
// Replies carry the request's id and the type "ok" or "error" (payload.reason).
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

namespace dca::wire {

/// The protocol version exchanged in the handshake (host/net/auth).
inline constexpr std::int64_t kProtocolVersion = 1;
/// The default largest body accepted by the decoder.
inline constexpr std::size_t kDefaultMaxFrame = 16u << 20;
/// The deepest nesting of arrays and maps accepted by the decoder (and produced by the encoder).
inline constexpr int kMaxDepth = 64;
/// The size of the length prefix.
inline constexpr std::size_t kHeaderSize = 4;

/// A msgpack value: nil, boolean, integer, float, string (bytes; msgpack str or bin), array or map.
/// Maps keep their order and may have keys of any type (Lua tables with integer keys), though payload maps
/// use string keys.
class Value {
 public:
  using Array = std::vector<Value>;
  using Map = std::vector<std::pair<Value, Value>>;
  struct Nil {
    bool operator==(const Nil&) const = default;
  };

  Value() = default;                                   ///< nil
  Value(bool b) : v_(b) {}                             ///< boolean
  Value(int i) : v_(std::int64_t{i}) {}                ///< integer
  Value(std::int64_t i) : v_(i) {}                     ///< integer
  Value(std::uint64_t i) : v_(static_cast<std::int64_t>(i)) {}  ///< integer (values above INT64_MAX wrap)
  Value(double d) : v_(d) {}                           ///< float
  Value(const char* s) : v_(std::string(s)) {}         ///< string
  Value(std::string s) : v_(std::move(s)) {}           ///< string
  Value(std::string_view s) : v_(std::string(s)) {}    ///< string
  Value(Array a) : v_(std::move(a)) {}                 ///< array
  Value(Map m) : v_(std::move(m)) {}                   ///< map

  /// An empty map.
  static Value map() { return Value(Map{}); }
  /// An empty array.
  static Value array() { return Value(Array{}); }

  bool is_nil() const { return std::holds_alternative<Nil>(v_); }
  bool is_bool() const { return std::holds_alternative<bool>(v_); }
  bool is_int() const { return std::holds_alternative<std::int64_t>(v_); }
  bool is_float() const { return std::holds_alternative<double>(v_); }
  bool is_number() const { return is_int() || is_float(); }
  bool is_string() const { return std::holds_alternative<std::string>(v_); }
  bool is_array() const { return std::holds_alternative<Array>(v_); }
  bool is_map() const { return std::holds_alternative<Map>(v_); }

  /// The value as a boolean (false unless it is the boolean true).
  bool as_bool() const { return is_bool() && std::get<bool>(v_); }
  /// The value as an integer (floats truncated; `fallback` for anything else).
  std::int64_t as_int(std::int64_t fallback = 0) const;
  /// The value as a float (integers converted; `fallback` for anything else).
  double as_float(double fallback = 0.0) const;
  /// The string, or "" when the value is not a string.
  const std::string& as_string() const;
  /// The array (an empty one when the value is not an array).
  const Array& as_array() const;
  /// The map (an empty one when the value is not a map).
  const Map& as_map() const;
  /// Mutable access: turns the value into an empty array/map first when it is not one.
  Array& array_ref();
  Map& map_ref();

  /// The value under the string key `key` in a map, or nullptr (also when this is not a map).
  const Value* find(std::string_view key) const;
  /// The value under `key`, or a nil value.
  const Value& operator[](std::string_view key) const;
  /// Sets `key` in a map (the value becomes a map if it is not one); returns *this for chaining.
  Value& set(std::string_view key, Value v);

  /// A short human-readable rendering (for logs and test failures), e.g. {argv = ["a", 1], ok = true}.
  std::string str() const;

  bool operator==(const Value& o) const { return v_ == o.v_; }

 private:
  std::variant<Nil, bool, std::int64_t, double, std::string, Array, Map> v_;
};

/// One control-plane message.
struct Message {
  std::string type;              ///< "spawn", "ok", "error", "exit", ...
  std::uint64_t id = 0;          ///< request id; 0 for events
  Value payload = Value::map();  ///< always a map

  bool operator==(const Message&) const = default;
};

/// A reply to `request`: type "ok" with `payload`.
Message make_reply(const Message& request, Value payload = Value::map());
/// An error reply to `request` (or an error event when request.id is 0): type "error", payload {reason}.
Message make_error(const Message& request, std::string_view reason);

/// Appends the frame of `m` (length prefix and body) to `out`. Fails (returns false, with *error) only when a
/// value nests deeper than kMaxDepth or the body would exceed 4 GiB.
bool encode(const Message& m, std::string& out, std::string* error = nullptr);
/// The frame of `m` (empty string if it cannot be encoded, see above).
std::string encode(const Message& m);
/// Appends the msgpack encoding of one value (no frame) to `out`.
void encode_value(const Value& v, std::string& out);

/// Decodes exactly one msgpack value (no frame) from `bytes` into `out`, with the decoder's limits (depth,
/// sizes); false with *error when `bytes` is empty, truncated, malformed or has trailing bytes.
bool decode_value(std::string_view bytes, Value& out, std::string* error = nullptr);

/// The result of decoding.
struct Decoded {
  enum class Status {
    kMessage,   ///< one message decoded: `message`, and `consumed` bytes used
    kNeedMore,  ///< the input holds no complete frame yet (never for a body on its own)
    kError,     ///< the input is malformed or oversize: `error` says why; the connection must be closed
  };
  Status status = Status::kNeedMore;
  Message message;
  std::size_t consumed = 0;
  std::string error;
};

/// Decodes the message body (msgpack, without the length prefix) in `body`, which must hold exactly one
/// message: any truncation, trailing byte, wrong shape or nesting deeper than kMaxDepth is an error.
Decoded decode_body(std::string_view body);
/// Decodes the first frame of `bytes` (which starts at a frame boundary): kNeedMore while incomplete, kError
/// as soon as the length prefix exceeds `max_frame` (no need to wait for the body) or the body is malformed.
Decoded decode_frame(std::string_view bytes, std::size_t max_frame = kDefaultMaxFrame);

}  // namespace dca::wire
