#pragma once
// host/codec: pure encoders and decoders. No Asio, no Beast, no socket, nothing of host/net or host/web.
// JSON <-> wire::Value, for the web monitor's messages (host/web) and its Lua side (core.json_encode/decode).
// Pure, no I/O. The decoder never throws and is bounded: at most kMaxDepth levels of nesting; any input that
// is not one well-formed JSON value (RFC 8259) is refused with the byte offset and the reason.
#include <span>
#include <string>
#include <string_view>

#include "host/codec/wire.h"

namespace dca::json {

/// Deepest nesting the decoder accepts.
inline constexpr int kMaxDepth = 64;

/// `v` as JSON: maps as objects (non-string keys written as their text), arrays, strings (bytes that are not
/// valid UTF-8 are escaped one by one as \u00XX), numbers (NaN and infinities as null), booleans, nil as null.
std::string encode(const wire::Value& v);
/// Appends `v` as JSON to `out`.
void encode(const wire::Value& v, std::string& out);
/// Appends `s` as a JSON string (quoted; invalid UTF-8 bytes escaped one by one).
void append_string(std::string& out, std::string_view s);
/// Appends `d` as a JSON number (shortest round-trip text; NaN and infinities as null).
void append_number(std::string& out, double d);
/// Appends `values` as a JSON array of numbers (each as append_number writes it).
void append_numbers(std::string& out, std::span<const double> values);
/// Parses `text` (one JSON value, surrounding blanks allowed). False with *error ("offset N: what") otherwise.
bool decode(std::string_view text, wire::Value* out, std::string* error);

}  // namespace dca::json
