// libFuzzer target for the control plane's frame decoder (host/wire). Every input must either be rejected with a
// reason, be incomplete, or decode to a message that encodes again and decodes to the same encoding.
//   build/<b>/bin/fuzz_wire [-runs=N] [corpus/]     (built when clang++ is present; see tests/fuzz/CMakeLists.txt)
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "host/codec/wire.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  const auto d = dca::wire::decode_frame(in, 1 << 20);
  if (d.status == dca::wire::Decoded::Status::kError && d.error.empty()) std::abort();
  if (d.status == dca::wire::Decoded::Status::kMessage) {
    if (d.consumed > size || !d.message.payload.is_map() || d.message.type.empty()) std::abort();
    const std::string again = dca::wire::encode(d.message);
    const auto d2 = dca::wire::decode_frame(again, 1 << 30);
    if (d2.status != dca::wire::Decoded::Status::kMessage || dca::wire::encode(d2.message) != again) std::abort();
  }
  // The body alone never asks for more.
  if (size > 4 && dca::wire::decode_body(in.substr(4)).status == dca::wire::Decoded::Status::kNeedMore) std::abort();
  return 0;
}
