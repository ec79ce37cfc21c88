#include "host/codec/mcap.h"

#include <gtest/gtest.h>

#include <string>

namespace {

using dca::mcap::Contents;
using dca::mcap::Writer;

uint64_t le(const std::string& b, size_t at, int bytes) {
  uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v |= static_cast<uint64_t>(static_cast<unsigned char>(b.at(at + i))) << (8 * i);
  return v;
}

using dca::mcap::Compression;

// A file with two channels and `n` messages on each, chunks of about `chunk` bytes.
std::string sample(int n, size_t chunk, dca::mcap::Stats* stats = nullptr, Compression how = Compression::none) {
  std::string file;
  Writer w([&](std::string_view b) { file.append(b); return true; }, "test", chunk, how);
  const auto a = w.add_channel("/a", "A", R"({"type":"object","properties":{"x":{"type":"number"}}})");
  const auto b = w.add_channel("/b", "B", R"({"type":"object","properties":{"y":{"type":"number"}}})");
  for (int i = 0; i < n; ++i) {
    w.write(a, 1000u * i, "{\"x\":" + std::to_string(i) + "}");
    w.write(b, 1000u * i, "{\"y\":" + std::to_string(-i) + "}");
  }
  EXPECT_TRUE(w.finish());
  if (stats) *stats = w.stats();
  return file;
}

// The ros2 profile: the header says it, a CDR channel has a ros2msg schema and the offered_qos_profiles metadata,
// its bytes kept as they are, beside a JSON channel (docs/recording.md, "The ros2 profile").
TEST(McapTest, Ros2ProfileWritesCdrChannelsBesideJson) {
  std::string file;
  Writer w([&](std::string_view b) { file.append(b); return true; }, "test", 4096, Compression::none, "ros2");
  const auto cdr = w.add_channel({"/js", "sensor_msgs/msg/JointState", "std_msgs/Header header\n", true});
  const auto json = w.add_channel("/j", "J", "{}");
  const std::string bytes("\x00\x01\x00\x00\x07\x00\xff", 7);
  w.write(cdr, 5, bytes);
  w.write(json, 5, "{}");
  ASSERT_TRUE(w.finish());
  // the header record (op 0x01) right after the 8-byte magic: its profile string first
  ASSERT_EQ(file[8], '\x01');
  EXPECT_EQ(le(file, 17, 4), 4u);
  EXPECT_EQ(file.substr(21, 4), "ros2");
  EXPECT_NE(file.find("offered_qos_profiles"), std::string::npos);
  Contents c;
  std::string error;
  ASSERT_TRUE(dca::mcap::read(file, &c, &error)) << error;
  EXPECT_EQ(c.channels.at(cdr).message_encoding, "cdr");
  EXPECT_EQ(c.channels.at(cdr).schema_encoding, "ros2msg");
  EXPECT_EQ(c.channels.at(cdr).schema_name, "sensor_msgs/msg/JointState");
  EXPECT_EQ(c.channels.at(json).message_encoding, "json");
  EXPECT_EQ(c.channels.at(json).schema_encoding, "jsonschema");
  ASSERT_EQ(c.messages.size(), 2u);
  EXPECT_EQ(c.messages[0].data, bytes);
}

TEST(McapTest, Crc32IsZlibs) {
  EXPECT_EQ(dca::mcap::crc32("123456789"), 0xCBF43926u);
  EXPECT_EQ(dca::mcap::crc32(""), 0u);
}

TEST(McapTest, RoundTrip) {
  dca::mcap::Stats stats;
  const std::string file = sample(100, 512, &stats);
  EXPECT_EQ(stats.messages, 200u);
  EXPECT_GT(stats.chunks, 3u);
  EXPECT_EQ(stats.per_channel.at(1), 100u);
  EXPECT_EQ(stats.end_time, 99000u);
  Contents c;
  std::string error;
  ASSERT_TRUE(dca::mcap::read(file, &c, &error)) << error;
  ASSERT_EQ(c.channels.size(), 2u);
  EXPECT_EQ(c.channels.at(1).topic, "/a");
  EXPECT_EQ(c.channels.at(2).schema_name, "B");
  EXPECT_EQ(c.channels.at(2).schema_encoding, "jsonschema");
  EXPECT_EQ(c.channels.at(2).message_encoding, "json");
  ASSERT_EQ(c.messages.size(), 200u);
  EXPECT_EQ(c.messages[3].data, "{\"y\":-1}");
  EXPECT_EQ(c.messages[3].log_time, 1000u);
  EXPECT_TRUE(c.summary);
  EXPECT_TRUE(c.statistics);
  EXPECT_EQ(c.chunks, stats.chunks);
  EXPECT_EQ(c.chunk_indexes, stats.chunks);
}

// The footer and the summary's offsets point where the spec says: every chunk index at its chunk and its
// message indexes, every summary offset at a group of records of its opcode.
TEST(McapTest, SummaryPointsAtRecords) {
  const std::string f = sample(50, 300);
  const size_t footer = f.size() - 8 - 29;
  ASSERT_EQ(f[footer], 0x02);
  const uint64_t summary = le(f, footer + 9, 8), offsets = le(f, footer + 17, 8);
  ASSERT_GT(summary, 0u);
  ASSERT_GT(offsets, summary);
  EXPECT_EQ(le(f, footer + 25, 4), dca::mcap::crc32(std::string_view(f).substr(summary, footer + 25 - summary)));
  EXPECT_EQ(f[summary - 13], 0x0F) << "the data end record precedes the summary";
  int chunk_indexes = 0, groups = 0;
  for (size_t at = summary; at < offsets;) {
    const int op = f[at];
    const uint64_t len = le(f, at + 1, 8);
    if (op == 0x08) {
      ++chunk_indexes;
      const uint64_t chunk = le(f, at + 9 + 16, 8), length = le(f, at + 9 + 24, 8);
      EXPECT_EQ(f[chunk], 0x06);
      EXPECT_EQ(f[chunk + length], 0x07) << "message indexes follow the chunk";
      const uint64_t map = le(f, at + 9 + 32, 4);
      EXPECT_EQ(map, 20u) << "two channels";
      for (uint64_t e = 0; e < map; e += 10) EXPECT_EQ(f[le(f, at + 9 + 36 + e + 2, 8)], 0x07);
    }
    at += 9 + len;
  }
  for (size_t at = offsets; at < footer; at += 9 + 17) {
    ASSERT_EQ(f[at], 0x0E);
    EXPECT_EQ(static_cast<int>(f[le(f, at + 10, 8)]), f[at + 9]) << "a group starts with its opcode";
    ++groups;
  }
  EXPECT_GT(chunk_indexes, 2);
  EXPECT_EQ(groups, 4) << "schemas, channels, chunk indexes, statistics";
}

TEST(McapTest, MalformedInputIsAnErrorNotACrash) {
  const std::string file = sample(20, 200);
  Contents c;
  std::string error;
  for (size_t n = 0; n < file.size(); n += 7) {
    EXPECT_FALSE(dca::mcap::read(file.substr(0, n), &c, &error)) << n;
  }
  for (size_t at = 0; at < file.size(); ++at) {
    std::string bad = file;
    bad[at] = static_cast<char>(bad[at] ^ 0xff);
    dca::mcap::read(bad, &c, &error);  // may or may not be an error; must not crash
  }
  EXPECT_FALSE(dca::mcap::read("not mcap", &c, &error));
  EXPECT_NE(error.find("offset 0"), std::string::npos) << error;
}

TEST(McapTest, SinkFailureIsReported) {
  int calls = 0;
  Writer w([&](std::string_view) { return ++calls < 3; });
  const auto ch = w.add_channel("/a", "A", "{}");
  w.write(ch, 1, "{}");
  EXPECT_FALSE(w.finish());
}

// Chunks compressed with zstd and lz4 read back to the same messages, the file smaller; the chunk indexes name
// the compression and both sizes.
TEST(McapTest, CompressedChunksRoundTrip) {
  const std::string plain = sample(300, 4096);
  Contents want;
  std::string error;
  ASSERT_TRUE(dca::mcap::read(plain, &want, &error)) << error;
  for (const Compression how : {Compression::zstd, Compression::lz4}) {
    dca::mcap::Stats stats;
    const std::string file = sample(300, 4096, &stats, how);
    EXPECT_LT(file.size(), plain.size() * 2 / 3) << dca::mcap::compression_name(how);
    EXPECT_EQ(stats.bytes, file.size());
    EXPECT_GT(stats.chunk_bytes, file.size());
    EXPECT_NE(file.find(dca::mcap::compression_name(how)), std::string::npos);
    Contents c;
    ASSERT_TRUE(dca::mcap::read(file, &c, &error)) << error;
    ASSERT_EQ(c.messages.size(), want.messages.size());
    for (size_t i = 0; i < c.messages.size(); ++i) {
      EXPECT_EQ(c.messages[i].data, want.messages[i].data);
      EXPECT_EQ(c.messages[i].log_time, want.messages[i].log_time);
    }
    EXPECT_EQ(c.chunks, stats.chunks);
    dca::mcap::Summary s;
    const dca::mcap::Fetch fetch = [&](uint64_t at, uint64_t n, std::string* out) {
      if (at > file.size() || n > file.size() - at) return false;
      *out = file.substr(at, n);
      return true;
    };
    ASSERT_TRUE(dca::mcap::read_summary(fetch, file.size(), &s, &error)) << error;
    ASSERT_EQ(s.chunks.size(), stats.chunks);
    EXPECT_EQ(s.chunks[0].compression, dca::mcap::compression_name(how));
    EXPECT_LT(s.chunks[0].compressed, s.chunks[0].uncompressed);
  }
  Compression parsed{};
  EXPECT_TRUE(dca::mcap::parse_compression("lz4", &parsed));
  EXPECT_EQ(parsed, Compression::lz4);
  EXPECT_FALSE(dca::mcap::parse_compression("gzip", &parsed));
}

// A compressed chunk's bytes changed, cut, or stating more than the limits: an error, never a crash.
TEST(McapTest, CorruptCompressedChunksAreErrors) {
  for (const Compression how : {Compression::zstd, Compression::lz4}) {
    const std::string file = sample(40, 600, nullptr, how);
    Contents c;
    std::string error;
    for (size_t n = 0; n < file.size(); n += 5) EXPECT_FALSE(dca::mcap::read(file.substr(0, n), &c, &error)) << n;
    for (size_t at = 0; at < file.size(); ++at) {
      std::string bad = file;
      bad[at] = static_cast<char>(bad[at] ^ 0x5a);
      dca::mcap::read(bad, &c, &error);  // may or may not be an error; must not crash
    }
    // every byte of a chunk's compressed records changed: refused (by the decompressor, or by the CRC), or read to
    // the same messages (a bit of a frame's header that changes nothing)
    Contents want;
    ASSERT_TRUE(dca::mcap::read(file, &want, &error)) << error;
    dca::mcap::Summary s;
    const dca::mcap::Fetch fetch = [&](uint64_t at, uint64_t n, std::string* out) {
      if (at > file.size() || n > file.size() - at) return false;
      *out = file.substr(at, n);
      return true;
    };
    ASSERT_TRUE(dca::mcap::read_summary(fetch, file.size(), &s, &error)) << error;
    ASSERT_GT(s.chunks.size(), 2u);
    for (const auto& ci : s.chunks) {
      const size_t records = ci.offset + 9 + 40 + ci.compression.size();
      ASSERT_EQ(records + ci.compressed, ci.offset + ci.length);
      for (size_t at = records; at < records + ci.compressed; ++at) {
        std::string bad = file;
        bad[at] = static_cast<char>(bad[at] ^ 0x5a);
        if (!dca::mcap::read(bad, &c, &error)) continue;
        ASSERT_EQ(c.messages.size(), want.messages.size()) << dca::mcap::compression_name(how) << " at " << at;
        for (size_t i = 0; i < c.messages.size(); ++i) EXPECT_EQ(c.messages[i].data, want.messages[i].data);
      }
    }
    // the limit per chunk, and per file
    dca::mcap::Limits small;
    small.max_chunk = 100;
    EXPECT_FALSE(dca::mcap::read(file, &c, &error, small));
    EXPECT_NE(error.find("over the limit of 100 per chunk"), std::string::npos) << error;
    small.max_chunk = 1 << 20, small.max_total = 1000;
    EXPECT_FALSE(dca::mcap::read(file, &c, &error, small));
    EXPECT_NE(error.find("per file"), std::string::npos) << error;
  }
}

// A chunk that decompresses to more (or less) than it states is refused without writing past what it states: a
// message of 4 MiB of zeros (some hundred bytes compressed) in a chunk made to say it holds 1000 bytes.
TEST(McapTest, ChunkOtherThanItStatesIsRefused) {
  for (const Compression how : {Compression::zstd, Compression::lz4}) {
    std::string file;
    Writer w([&](std::string_view b) { file.append(b); return true; }, "test", 1 << 20, how);
    w.write(w.add_channel("/a", "A", "{}"), 1, "{\"x\":\"" + std::string(4 << 20, '0') + "\"}");
    ASSERT_TRUE(w.finish());
    ASSERT_LT(file.size(), 100000u);
    Contents c;
    std::string error;
    ASSERT_TRUE(dca::mcap::read(file, &c, &error)) << error;
    const std::string name = dca::mcap::compression_name(how);
    const size_t at = file.find(std::string(1, static_cast<char>(name.size())) + std::string(3, '\0') + name);
    ASSERT_NE(at, std::string::npos);
    const size_t size_at = at - 4 - 8;  // the records' size before compression, then their CRC
    ASSERT_EQ(le(file, size_at, 8), (4u << 20) + 8 + 31);
    for (const uint64_t stated : {uint64_t{1000}, uint64_t{(4u << 20) + 100}}) {
      std::string bad = file;
      for (int k = 0; k < 8; ++k) bad[size_at + k] = static_cast<char>((stated >> (8 * k)) & 0xff);
      EXPECT_FALSE(dca::mcap::read(bad, &c, &error)) << name << " " << stated;
      EXPECT_NE(error.find(name), std::string::npos) << error;
    }
  }
}

// The summary read through fetches of the file's end: a few small reads; then one chunk read alone.
TEST(McapTest, SummaryAndOneChunkReadAlone) {
  dca::mcap::Stats stats;
  const std::string file = sample(5000, 4096, &stats, Compression::zstd);
  uint64_t fetched = 0;
  int fetches = 0;
  const dca::mcap::Fetch fetch = [&](uint64_t at, uint64_t n, std::string* out) {
    if (at > file.size() || n > file.size() - at) return false;
    fetched += n, ++fetches;
    *out = file.substr(at, n);
    return true;
  };
  dca::mcap::Summary s;
  std::string error;
  ASSERT_TRUE(dca::mcap::read_summary(fetch, file.size(), &s, &error)) << error;
  EXPECT_EQ(fetches, 3);
  EXPECT_LT(fetched, file.size() / 4) << "the summary only";
  ASSERT_EQ(s.chunks.size(), stats.chunks);
  ASSERT_EQ(s.channels.size(), 2u);
  EXPECT_EQ(s.channels.at(2).topic, "/b");
  EXPECT_EQ(s.messages, 10000u);
  EXPECT_EQ(s.per_channel.at(1), 5000u);
  EXPECT_EQ(s.end_time, 4999000u);
  const auto& mid = s.chunks[s.chunks.size() / 2];
  EXPECT_EQ(mid.channels, (std::vector<uint16_t>{1, 2}));
  fetched = 0;
  std::vector<Contents::Message> got;
  ASSERT_TRUE(dca::mcap::read_chunk(fetch, s, mid, &got, &error)) << error;
  EXPECT_EQ(fetched, mid.length);
  ASSERT_FALSE(got.empty());
  EXPECT_EQ(got.front().log_time, mid.start_time);
  EXPECT_EQ(got.back().log_time, mid.end_time);
  // a chunk index that points elsewhere, or a file without a summary: errors
  auto wrong = mid;
  wrong.offset += 1;
  EXPECT_FALSE(dca::mcap::read_chunk(fetch, s, wrong, &got, &error));
  wrong.offset = file.size();
  EXPECT_FALSE(dca::mcap::read_chunk(fetch, s, wrong, &got, &error));
  for (size_t cut = 0; cut < 60; ++cut) {  // the footer and summary changed byte by byte: no crash
    std::string bad = file;
    bad[file.size() - 1 - cut * 7 % 2000] ^= 0x33;
    const dca::mcap::Fetch f2 = [&](uint64_t at, uint64_t n, std::string* out) {
      if (at > bad.size() || n > bad.size() - at) return false;
      *out = bad.substr(at, n);
      return true;
    };
    if (dca::mcap::read_summary(f2, bad.size(), &s, &error))
      for (const auto& ci : s.chunks) dca::mcap::read_chunk(f2, s, ci, &got, &error);
  }
}

}  // namespace
