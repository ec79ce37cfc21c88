// libFuzzer target for the MCAP reader (host/mcap), chunks compressed or not. Every input must either be rejected
// with a reason, or read to contents whose messages are all on known channels; accepted contents written again by
// the Writer (uncompressed, zstd or lz4 by the count of messages) read back to the same messages.
//   build/<b>/bin/fuzz_mcap [-runs=N] [corpus/]     (built when clang++ is present; see tests/fuzz/CMakeLists.txt)
#include <cstdint>
#include <cstdlib>
#include <map>
#include <string>
#include <string_view>

#include "host/codec/mcap.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  dca::mcap::Contents c;
  std::string error;
  dca::mcap::Limits limits;  // small: a chunk that says it holds more is refused before it is decompressed
  limits.max_chunk = 1 << 20, limits.max_total = 4 << 20;
  if (!dca::mcap::read(in, &c, &error, limits)) {
    if (error.empty()) std::abort();
    return 0;
  }
  for (const auto& m : c.messages)
    if (!c.channels.count(m.channel)) std::abort();
  if (c.channels.size() > 1000) return 0;
  std::string again;
  const auto how = c.messages.size() % 3 == 0 ? dca::mcap::Compression::none
                   : c.messages.size() % 3 == 1 ? dca::mcap::Compression::zstd : dca::mcap::Compression::lz4;
  dca::mcap::Writer w([&](std::string_view b) { again.append(b); return true; }, "fuzz", 512, how);
  std::map<uint16_t, uint16_t> id;
  for (const auto& [k, ch] : c.channels) id[k] = w.add_channel(ch.topic, ch.schema_name, "{}");
  for (const auto& m : c.messages) w.write(id[m.channel], m.log_time, m.data);
  if (!w.finish()) std::abort();
  dca::mcap::Contents c2;
  if (!dca::mcap::read(again, &c2, &error) || c2.messages.size() != c.messages.size()) std::abort();
  for (size_t i = 0; i < c.messages.size(); ++i)
    if (c2.messages[i].data != c.messages[i].data || c2.messages[i].log_time != c.messages[i].log_time) std::abort();
  return 0;
}
