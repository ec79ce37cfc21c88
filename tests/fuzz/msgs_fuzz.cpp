// libFuzzer target for the CDR decoder of dca's ROS 2 messages (sdk/include/dca/msgs_cdr.h) and the table that
// checks and shows them (host/codec/msgs.cpp). Every input, read as every type, must be refused with an offset
// inside it, or decode to a message that encodes again to bytes that decode and encode to the same bytes; the table's
// check, JSON and msgpack must agree with the decoder.
//   build/<b>/bin/fuzz_msgs [-runs=N]     (built when clang++ is present; see tests/fuzz/CMakeLists.txt)
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <span>
#include <vector>

#include <dca/msgs.h>
#include <dca/msgs_cdr.h>
#include <dca/msgs_describe.h>

#include "host/codec/msgs.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::byte> in(reinterpret_cast<const std::byte*>(data), size);
  dca::msgs::for_each_message_type([&]<class M>() {
    const auto m = std::make_unique<M>();
    const dca::msgs::CdrResult r = dca::msgs::cdr_decode(in, *m);
    if (r.offset > size) std::abort();
    const auto* info = dca::msgs::find_type(M::ros_name);
    if (!info || info->valid(in) != (r && size - r.offset < 4)) std::abort();
    if (info->json(in).empty()) std::abort();
    if (!r) return;
    std::vector<std::byte> again(dca::msgs::cdr_max_size<M>);
    again.resize(dca::msgs::cdr_encode(*m, again));
    const auto back = std::make_unique<M>();  // compared as bytes: a NaN is not equal to itself
    if (again.empty() || !dca::msgs::cdr_decode(again, *back)) std::abort();
    std::vector<std::byte> third(again.size());
    if (dca::msgs::cdr_encode(*back, third) != again.size() || third != again) std::abort();
    msgpack::sbuffer sb;
    msgpack::packer<msgpack::sbuffer> pk(sb);
    info->pack(in, pk);
  });
  return 0;
}
