#pragma once
// Data-plane frames (pure code, no I/O): what travels on a data socket between two endpoints (host/endpoint).
//
//   frame = length (4 bytes, big-endian, counts kind + body) | kind (1 byte) | body
//
//   Auth       both ways, before anything else: one message of the cluster-key handshake (host/auth.h, keyed
//              with host/endpoint.h's data_key), as a control-plane message body (host/wire, no length prefix)
//   Hello      source -> destination, first frame after Auth: msgpack map {from, out, to, in, set, mode, queue,
//              type, size}
//   HelloOk    destination -> source: the input exists and fits; samples may flow
//   HelloError destination -> source: body is the reason (UTF-8); the destination then closes
//   Sample     source -> destination: body is the sample's bytes (push)
//   PullRequest destination -> source: empty body; the source answers with Pulled
//   Pulled     source -> destination: body is the latest sample (pull answer)
//
// Fuzzed: tests/fuzz/data_frame_fuzz.cpp.
#include <cstddef>
#include <cstdint>
#include <string>

#include "host/port.h"
#include "host/wire.h"

namespace dca::data_frame {

/// Frame kinds.
enum class Kind : std::uint8_t {
  Hello = 1, HelloOk = 2, HelloError = 3, Sample = 4, PullRequest = 5, Pulled = 6, Auth = 7
};

/// Bytes before a frame's body.
inline constexpr std::size_t kHeader = 5;
/// Largest accepted frame (length field), like the control plane's default.
inline constexpr std::uint32_t kMaxFrame = 16u << 20;
/// Largest frame (length field) accepted before the peer has authenticated: the handshake's messages are
/// under 200 bytes, so a connection announcing more is refused as soon as its length prefix arrives.
inline constexpr std::uint32_t kMaxAuthFrame = 512;

/// Writes a header for a frame of `kind` with a body of `body_size` bytes into h[0..5).
void put_header(std::byte* h, Kind kind, std::size_t body_size);

/// One parsed frame, pointing into the buffer it was parsed from.
struct Frame {
  Kind kind = Kind::Sample;
  Bytes body;
};

/// Outcome of parse_frame.
enum class Parse : std::uint8_t { Ok, NeedMore, Error };

/// Parses the frame at the start of `buf`. Ok: `f` and `used` are set. NeedMore: `used` is the total size the
/// frame will need (0 when even the length is incomplete). Error: *error says why (a length over `max_frame`,
/// known from the first 4 bytes; empty; unknown kind).
Parse parse_frame(Bytes buf, Frame& f, std::size_t& used, std::string* error, std::uint32_t max_frame = kMaxFrame);

/// An Auth body: the handshake message `m` (wire body, no length prefix).
std::string encode_auth(const wire::Message& m);
/// Decodes an Auth body; false with *error when it is not one message. Never throws.
bool decode_auth(Bytes body, wire::Message& m, std::string* error);

/// Limits on a Hello's fields, checked by decode_hello before anything is allocated for them.
inline constexpr std::uint32_t kMaxQueue = 4096;        ///< an input's queue capacity (samples)
inline constexpr std::uint32_t kMaxSize = 1u << 16;     ///< a port's vector size (elements)
inline constexpr std::size_t kMaxName = 256;            ///< a component, port or set name (bytes)

/// The Hello's fields.
struct Hello {
  ConnectRequest request;
  PortSpec out;  ///< the source output's spec (name = request.out)
};

/// Packs a Hello body (msgpack map).
std::string encode_hello(const Hello& h);
/// Decodes a Hello body; false with *error on malformed input or a field out of its limits (a queue over
/// kMaxQueue, a size over kMaxSize, a name empty where one is needed, longer than kMaxName or holding a
/// control character). Never throws.
bool decode_hello(Bytes body, Hello& h, std::string* error);

}  // namespace dca::data_frame
