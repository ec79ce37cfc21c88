// libFuzzer target for the data plane's frame parser and body decoders (host/data_frame). Every input must
// either be rejected with a reason, be incomplete (asking for more than it holds), or parse to a frame inside
// the input; a Hello body must either be refused with a reason or decode to one that encodes and decodes again
// to the same encoding; a Peer body the same; an Auth body is refused with a reason or decodes to a message.
//   build/<b>/bin/fuzz_data_frame [-runs=N] [tests/fuzz/data_frame_corpus/]   (see tests/fuzz/CMakeLists.txt)
#include <cstdint>
#include <cstdlib>
#include <string>

#include "host/codec/data_frame.h"

namespace {

namespace df = dca::data_frame;

dca::Bytes bytes_of(const std::string& s) { return {reinterpret_cast<const std::byte*>(s.data()), s.size()}; }

// The Hello decoder on `body`: refused with a reason, or a round trip that is stable.
void check_hello(dca::Bytes body) {
  df::Hello h;
  std::string error;
  if (!df::decode_hello(body, h, &error)) {
    if (error.empty()) std::abort();
    return;
  }
  const std::string again = df::encode_hello(h);
  df::Hello h2;
  if (!df::decode_hello(bytes_of(again), h2, &error) || df::encode_hello(h2) != again) std::abort();
}

// The Peer decoder on `body`: refused with a reason, or a stable round trip.
void check_peer(dca::Bytes body) {
  dca::Location l;
  std::string error;
  if (!df::decode_peer(body, l, &error)) {
    if (error.empty()) std::abort();
    return;
  }
  const std::string again = df::encode_peer(l);
  dca::Location l2;
  if (!df::decode_peer(bytes_of(again), l2, &error) || df::encode_peer(l2) != again) std::abort();
}

// The Auth decoder on `body`: refused with a reason, or a message that encodes again.
void check_auth(dca::Bytes body) {
  dca::wire::Message m;
  std::string error;
  if (!df::decode_auth(body, m, &error)) {
    if (error.empty()) std::abort();
    return;
  }
  const std::string again = df::encode_auth(m);
  dca::wire::Message m2;
  if (!df::decode_auth(bytes_of(again), m2, &error) || m2.type != m.type) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const dca::Bytes in(reinterpret_cast<const std::byte*>(data), size);
  df::Frame f;
  std::size_t used = 0;
  std::string error;
  switch (df::parse_frame(in, f, used, &error)) {
    case df::Parse::Error:
      if (error.empty()) std::abort();
      break;
    case df::Parse::NeedMore:
      if (used != 0 && used <= size) std::abort();
      break;
    case df::Parse::Ok:
      if (used > size || used != df::kHeader + f.body.size()) std::abort();
      if (f.kind == df::Kind::Hello) check_hello(f.body);
      if (f.kind == df::Kind::Peer) check_peer(f.body);
      if (f.kind == df::Kind::Auth) check_auth(f.body);
      break;
  }
  check_hello(in);  // the input as a Hello, Peer and Auth body on its own
  check_peer(in);
  check_auth(in);
  return 0;
}
