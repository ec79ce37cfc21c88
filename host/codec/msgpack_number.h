#pragma once
// host/codec: pure encoders and decoders. No Asio, no Beast, no socket, nothing of host/net or host/web.
// A double onto msgpack as dca's wire carries it (docs/control-plane.md, "Messages" 9). msgpack-c's
// pack_double writes a whole double as an integer (2.0 as 2), which dca keeps; but a whole double from 2^63
// up would become an unsigned integer above INT64_MAX (and at 2^64 msgpack-c converts out of range): those go
// out as float64, so what dca writes, dca reads back as the same double.
#include <cstdint>
#include <cstring>

#include <msgpack.hpp>

namespace dca::wire {

inline constexpr double kTwoTo63 = 9223372036854775808.0;  // the first whole double beyond int64

template <class Stream>
void pack_real(msgpack::packer<Stream>& pk, double d) {
  if (!(d >= kTwoTo63)) {  // (NaN too: msgpack-c writes it as float64)
    pk.pack_double(d);
    return;
  }
  std::uint64_t bits = 0;
  std::memcpy(&bits, &d, sizeof bits);
  char buf[9];
  buf[0] = static_cast<char>(0xcb);  // float 64, big-endian
  for (int i = 0; i < 8; ++i) buf[1 + i] = static_cast<char>((bits >> (56 - 8 * i)) & 0xff);
  pk.pack_str_body(buf, sizeof buf);  // (the raw bytes: pack_str_body writes its argument as it is)
}

// A float stays float32 on the wire (a message's float32 field), below 2^63.
template <class Stream>
void pack_real(msgpack::packer<Stream>& pk, float f) {
  if (!(static_cast<double>(f) >= kTwoTo63)) pk.pack_float(f);
  else pack_real(pk, static_cast<double>(f));
}

}  // namespace dca::wire
