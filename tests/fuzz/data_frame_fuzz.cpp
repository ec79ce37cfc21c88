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

// A body decoder on `body`: refused with a reason, or a value that encodes and decodes again to one that `same`
// matches with the first.
template <class T, class Same>
void check_decoder(dca::Bytes body, bool (*decode)(dca::Bytes, T&, std::string*), std::string (*encode)(const T&),
                   Same same) {
  T v;
  std::string error;
  if (!decode(body, v, &error)) {
    if (error.empty()) std::abort();
    return;
  }
  const std::string again = encode(v);
  T v2;
  if (!decode(bytes_of(again), v2, &error) || !same(v, v2)) std::abort();
}

// Hello and Peer: a round trip that is stable (the same encoding again); Auth: a message of the same type.
void check_bodies(dca::Bytes body) {
  check_decoder(body, df::decode_hello, df::encode_hello,
                [](const df::Hello& a, const df::Hello& b) { return df::encode_hello(a) == df::encode_hello(b); });
  check_decoder(body, df::decode_peer, df::encode_peer,
                [](const dca::Location& a, const dca::Location& b) { return df::encode_peer(a) == df::encode_peer(b); });
  check_decoder(body, df::decode_auth, df::encode_auth,
                [](const dca::wire::Message& a, const dca::wire::Message& b) { return a.type == b.type; });
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
      if (f.kind == df::Kind::Hello || f.kind == df::Kind::Peer || f.kind == df::Kind::Auth) check_bodies(f.body);
      break;
  }
  check_bodies(in);  // the input as a Hello, Peer and Auth body on its own
  return 0;
}
