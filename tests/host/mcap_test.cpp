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

// A file with two channels and `n` messages on each, chunks of about `chunk` bytes.
std::string sample(int n, size_t chunk, dca::mcap::Stats* stats = nullptr) {
  std::string file;
  Writer w([&](std::string_view b) { file.append(b); return true; }, "test", chunk);
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

}  // namespace
