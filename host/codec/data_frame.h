#pragma once
// host/codec: pure encoders and decoders. No Asio, no Beast, no socket, nothing of host/net or host/web.
// Data-plane frames (pure code, no I/O): what travels on a data socket between two endpoints (host/net/endpoint).
// One socket connection joins two endpoints and carries every link between them, both ways; each frame names
// its link.
//
//   frame = length (4 bytes, big-endian, counts everything after it) | kind (1 byte) | link (4 bytes, big-endian)
//           | body
//
// A link's id is chosen by its source endpoint; frames going source -> destination name it in the source's
// numbering, frames going back name the same id (the kind says which way a frame goes, so the two endpoints'
// numberings never meet). Connection-level frames (Auth, Peer, a refusal before Peer) carry link 0.
//
//   Auth       both ways, before anything else: one message of the cluster-key handshake (host/net/auth.h, keyed
//              with host/net/endpoint.h's data_key), as a control-plane message body (host/codec/wire, no length prefix)
//   Peer       opener -> acceptor, first frame after Auth: msgpack map {host, uds, tcp}, the opener's own data
//              addresses, so that the acceptor's links towards it use this connection too
//   Hello      source -> destination: opens link `link`: msgpack map {from, out, to, in, set, mode, queue, type,
//              size[, stamped = true]} (stamped: a tap's link, host/net/tap.h: each Sample body is the writer's clock
//              time, 8 bytes in host order, then the sample)
//   HelloOk    destination -> source: the input exists and fits; samples may flow
//   HelloError destination -> source: body is the reason (UTF-8). Link 0: the connection is refused and closes
//   Sample     source -> destination: body is the sample's bytes (push)
//   PullRequest destination -> source: empty body; the source answers with Pulled
//   Pulled     source -> destination: body is the latest sample (pull answer)
//   Close      source -> destination: the source removed the link (empty body)
//   Gone       destination -> source: the input went away; body is the reason
//
// Extending: a new field of one kind goes at the start of its body (the header stays 9 bytes for every kind).
// Fuzzed: tests/fuzz/data_frame_fuzz.cpp.
#include <cstddef>
#include <cstdint>
#include <string>

#include "host/codec/wire.h"
#include "host/port.h"

namespace dca::data_frame {

/// Frame kinds.
enum class Kind : std::uint8_t {
  Hello = 1, HelloOk = 2, HelloError = 3, Sample = 4, PullRequest = 5, Pulled = 6, Auth = 7, Peer = 8, Close = 9,
  Gone = 10
};
/// The largest kind's value.
inline constexpr std::uint8_t kLastKind = 10;

/// Bytes before a frame's body: length, kind, link.
inline constexpr std::size_t kHeader = 9;
/// Largest accepted frame (length field), like the control plane's default.
inline constexpr std::uint32_t kMaxFrame = 16u << 20;
/// Largest body a frame can carry: the receiver fails the whole connection on a longer one, so the sender
/// refuses it (the endpoint drops that sample and counts it).
inline constexpr std::size_t kMaxBody = kMaxFrame - (kHeader - 4);
/// Largest frame (length field) accepted before the peer has authenticated: the handshake's messages are
/// under 200 bytes, so a connection announcing more is refused as soon as its length prefix arrives.
inline constexpr std::uint32_t kMaxAuthFrame = 512;

/// Writes a header for a frame of `kind` on link `link` with a body of `body_size` bytes into h[0..kHeader).
void put_header(std::byte* h, Kind kind, std::uint32_t link, std::size_t body_size);

/// One parsed frame, pointing into the buffer it was parsed from.
struct Frame {
  Kind kind = Kind::Sample;
  std::uint32_t link = 0;
  Bytes body;
};

/// Outcome of parse_frame.
enum class Parse : std::uint8_t { Ok, NeedMore, Error };

/// Parses the frame at the start of `buf`. Ok: `f` and `used` are set. NeedMore: `used` is the total size the
/// frame will need (0 when even the length is incomplete). Error: *error says why (a length over `max_frame`,
/// known from the first 4 bytes; shorter than kind and link; unknown kind).
Parse parse_frame(Bytes buf, Frame& f, std::size_t& used, std::string* error, std::uint32_t max_frame = kMaxFrame);

/// An Auth body: the handshake message `m` (wire body, no length prefix).
std::string encode_auth(const wire::Message& m);
/// Decodes an Auth body; false with *error when it is not one message. Never throws.
bool decode_auth(Bytes body, wire::Message& m, std::string* error);

/// Limits on a Hello's fields, checked by decode_hello before anything is allocated for them.
inline constexpr std::uint32_t kMaxQueue = 4096;        ///< an input's queue capacity (samples)
inline constexpr std::uint32_t kMaxSize = 1u << 16;     ///< a port's vector size (elements)
inline constexpr std::uint64_t kMaxSerial = (1ull << 62) - 1;  ///< a hello's sender and serial (a msgpack int)
inline constexpr std::size_t kMaxName = 256;            ///< a component, port or set name (bytes)

/// The Hello's fields.
struct Hello {
  ConnectRequest request;
  PortSpec out;  ///< the source output's spec (name = request.out; type, size and a message port's message)
  /// The sending endpoint's random id and the number of hellos it had sent before this one: a link moved to
  /// another connection says hello twice, on two sockets whose frames may be read in either order; the reader
  /// keeps the later one (0, 0: a sender that does not say, taken as the latest).
  std::uint64_t sender = 0, serial = 0;
};

/// Packs a Hello body (msgpack map).
std::string encode_hello(const Hello& h);
/// Decodes a Hello body; false with *error on malformed input or a field out of its limits (a queue over
/// kMaxQueue, a size over kMaxSize, a name empty where one is needed, longer than kMaxName or holding a
/// control character). Never throws.
bool decode_hello(Bytes body, Hello& h, std::string* error);

/// Packs a Peer body: the opener's host name and data addresses (msgpack map {host, uds, tcp}).
std::string encode_peer(const Location& l);
/// Decodes a Peer body; false with *error when malformed or a field is too long (kMaxAddress) or holds a
/// control character. Never throws.
bool decode_peer(Bytes body, Location& l, std::string* error);
/// The longest address or host name a Peer may hold (bytes).
inline constexpr std::size_t kMaxAddress = 256;

}  // namespace dca::data_frame
