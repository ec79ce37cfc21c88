#include "host/codec/wire.h"

#include <gtest/gtest.h>

#include <limits>
#include <random>

namespace {

using dca::wire::Decoded;
using dca::wire::Message;
using dca::wire::Value;

// The bytes of a string literal (which may hold NULs), without its terminating NUL.
template <std::size_t N>
std::string B(const char (&s)[N]) {
  return std::string(s, N - 1);
}

Value payload_of(std::initializer_list<std::pair<const char*, Value>> kv) {
  Value v = Value::map();
  for (const auto& [k, e] : kv) v.set(k, e);
  return v;
}

// One message of every type the control plane uses (ARCHITECTURE.md, "How the pieces meet").
std::vector<Message> every_message_type() {
  const std::string nonce(32, '\x07');
  return {
      {"hello", 0, payload_of({{"version", 1}, {"nonce", nonce}})},
      {"challenge", 0, payload_of({{"version", 1}, {"nonce", nonce}, {"mac", std::string(32, '\xff')}})},
      {"proof", 0, payload_of({{"mac", std::string(32, '\0')}})},
      {"welcome", 0, Value::map()},
      {"ok", 7, payload_of({{"child", 3}, {"pid", 4242}})},
      {"error", 9, payload_of({{"reason", "no such name"}})},
      {"error", 0, payload_of({{"reason", "malformed frame"}})},
      {"spawn", 1, payload_of({{"argv", Value::Array{"dca", "node", "--type", "Gain"}}, {"name", "/sys/g"}})},
      {"exit", 0, payload_of({{"child", 3}, {"pid", 4242}, {"code", 3}})},
      {"exit", 0, payload_of({{"child", 4}, {"pid", 4243}, {"signal", "SIGSEGV"}})},
      {"kill", 2, payload_of({{"child", 4}, {"signal", "SIGKILL"}})},
      {"register", 3,
       payload_of({{"name", "/sys/g"},
                   {"endpoints", payload_of({{"host", "h1"}, {"control", "127.0.0.1:5000"}, {"pid", 77}})}})},
      {"lookup", 4, payload_of({{"name", "/sys/g"}, {"wait_ms", 500}})},
      {"unregister", 5, payload_of({{"name", "/sys/g"}})},
      {"init", 6, Value::map()},
      {"run", 7, payload_of({{"init", true}})},
      {"stop", 8, Value::map()},
      {"connect", 9,
       payload_of({{"out", "Out"}, {"to", "/sys/h"}, {"in", "In"}, {"set", "/sys:a[x]"}, {"mode", "push"}, {"queue", 8}})},
      {"activate", 10, payload_of({{"set", "/sys:a[x]"}})},
      {"deactivate", 11, payload_of({{"set", "/sys:a[x]"}})},
      {"read", 12, payload_of({{"port", "Out"}})},
      {"ports", 13, Value::map()},
      {"done", 0, payload_of({{"value", 2.5}})},
      {"aborted", 0, payload_of({{"reason", "limit exceeded"}})},
      {"ping", std::numeric_limits<std::uint64_t>::max(), Value::map()},
  };
}

Message decode_one(const std::string& frame) {
  const Decoded d = dca::wire::decode_frame(frame);
  EXPECT_EQ(d.status, Decoded::Status::kMessage) << d.error;
  EXPECT_EQ(d.consumed, frame.size());
  return d.message;
}

TEST(WireTest, RoundTripsEveryMessageType) {
  for (const auto& m : every_message_type()) {
    const std::string frame = dca::wire::encode(m);
    ASSERT_GT(frame.size(), dca::wire::kHeaderSize) << m.type;
    EXPECT_EQ(decode_one(frame), m) << m.type << " " << m.payload.str();
  }
}

TEST(WireTest, RoundTripsEveryValueKind) {
  Value::Map int_keys;
  int_keys.emplace_back(Value(1), Value("a"));
  int_keys.emplace_back(Value(3), Value("c"));  // a Lua table with a hole
  const Value payload = payload_of({
      {"nil", Value()},
      {"t", true},
      {"f", false},
      {"zero", 0},
      {"neg", std::numeric_limits<std::int64_t>::min()},
      {"max", std::numeric_limits<std::int64_t>::max()},
      {"pi", 3.141592653589793},
      {"tiny", -1e-300},
      {"bytes", B("a\0b\xff")},
      {"empty", ""},
      {"arr", Value::Array{1, 2.5, "x", Value::Array{}, Value::map()}},
      {"holes", Value(int_keys)},
      {"nested", payload_of({{"a", payload_of({{"b", payload_of({{"c", 1}})}})}})},
  });
  const Message m{"sample", 42, payload};
  EXPECT_EQ(decode_one(dca::wire::encode(m)), m);
}

// msgpack-c writes a whole double as an integer; from 2^63 up that would be an unsigned integer above INT64_MAX,
// which the decoder refused: a value written by one dca process could not be read by another (a controller's
// output of 1e19 in a `read` answer or a trace's digest). Found by fuzz_data_frame (decode, encode, decode).
TEST(WireTest, DoublesBeyondInt64RoundTripAndBigUnsignedIntegersReadAsDoubles) {
  for (const double d : {9223372036854775808.0, 1e19, 18446744073709551616.0, 1e300, -1e19, -9223372036854775808.0,
                         std::numeric_limits<double>::infinity()}) {
    Value back;
    std::string bytes;
    dca::wire::encode_value(Value(d), bytes);
    ASSERT_TRUE(dca::wire::decode_value(bytes, back)) << d;
    EXPECT_EQ(back.as_float(), d) << d;
    const Message m{"sample", 1, payload_of({{"x", d}})};
    EXPECT_EQ(decode_one(dca::wire::encode(m)).payload["x"].as_float(), d) << d;
  }
  // whole doubles inside int64 keep msgpack-c's integer form (as before)
  std::string two;
  dca::wire::encode_value(Value(2.0), two);
  EXPECT_EQ(two, std::string("\x02", 1));
  // another encoder's uint64 above INT64_MAX: the nearest double
  Value big;
  ASSERT_TRUE(dca::wire::decode_value(std::string("\xcf\xff\xff\xff\xff\xff\xff\xff\xff", 9), big));
  EXPECT_TRUE(big.is_float());
  EXPECT_EQ(big.as_float(), 18446744073709551615.0);
}

TEST(WireTest, DecodesOneValueAndRejectsTruncatedOrTrailingBytes) {
  const Value v(Value::Map{{Value("a"), Value(Value::Array{Value(1), Value(2.5), Value("x")})}, {Value(3), Value(true)}});
  std::string bytes;
  dca::wire::encode_value(v, bytes);
  Value back;
  std::string error;
  ASSERT_TRUE(dca::wire::decode_value(bytes, back, &error)) << error;
  EXPECT_EQ(back, v);
  EXPECT_FALSE(dca::wire::decode_value(bytes.substr(0, bytes.size() - 1), back, &error));
  EXPECT_NE(error.find("truncated value"), std::string::npos) << error;
  EXPECT_FALSE(dca::wire::decode_value(bytes + "x", back, &error));
  EXPECT_EQ(error, "1 trailing bytes after the value");
  EXPECT_FALSE(dca::wire::decode_value("", back, &error));
  EXPECT_EQ(error, "empty value");
}

TEST(WireTest, DecodesFramesBackToBack) {
  std::string two;
  const auto msgs = every_message_type();
  dca::wire::encode(msgs[0], two);
  dca::wire::encode(msgs[7], two);
  const Decoded a = dca::wire::decode_frame(two);
  ASSERT_EQ(a.status, Decoded::Status::kMessage);
  EXPECT_EQ(a.message, msgs[0]);
  const Decoded b = dca::wire::decode_frame(std::string_view(two).substr(a.consumed));
  ASSERT_EQ(b.status, Decoded::Status::kMessage);
  EXPECT_EQ(b.message, msgs[7]);
  EXPECT_EQ(a.consumed + b.consumed, two.size());
}

TEST(WireTest, RejectsOversizeFrameFromItsPrefixAlone) {
  const std::string prefix("\x01\x00\x00\x01", 4);  // 16 MiB + 1
  const Decoded d = dca::wire::decode_frame(prefix);
  EXPECT_EQ(d.status, Decoded::Status::kError);
  EXPECT_NE(d.error.find("exceeds the limit"), std::string::npos) << d.error;
  const std::string small = dca::wire::encode(every_message_type()[0]);
  const Decoded e = dca::wire::decode_frame(small, 8);
  EXPECT_EQ(e.status, Decoded::Status::kError) << "a limit of 8 bytes";
}

TEST(WireTest, RejectsEmptyFrame) {
  const Decoded d = dca::wire::decode_frame(B("\0\0\0\0"));
  EXPECT_EQ(d.status, Decoded::Status::kError);
  EXPECT_EQ(d.error, "empty frame");
}

TEST(WireTest, EveryTruncationIsIncompleteOrRejected) {
  for (const auto& m : every_message_type()) {
    const std::string frame = dca::wire::encode(m);
    const std::string_view body = std::string_view(frame).substr(dca::wire::kHeaderSize);
    for (std::size_t n = 0; n < frame.size(); ++n) {
      const Decoded d = dca::wire::decode_frame(std::string_view(frame).substr(0, n));
      EXPECT_EQ(d.status, Decoded::Status::kNeedMore) << m.type << " cut at " << n;
    }
    for (std::size_t n = 0; n < body.size(); ++n) {
      const Decoded d = dca::wire::decode_body(body.substr(0, n));
      EXPECT_EQ(d.status, Decoded::Status::kError) << m.type << " body cut at " << n;
      EXPECT_FALSE(d.error.empty());
    }
  }
}

// Every single-byte corruption (several patterns at each position) is either rejected with a reason or decodes
// to a well-formed message that encodes again; never a crash (ASan and UBSan watch this in CI).
TEST(WireTest, EveryByteCorruptionIsRejectedOrDecodedSafely) {
  std::size_t rejected = 0, decoded = 0;
  for (const auto& m : every_message_type()) {
    const std::string frame = dca::wire::encode(m);
    for (std::size_t i = 0; i < frame.size(); ++i) {
      for (unsigned char x : {0x01, 0x80, 0xff, 0x10, 0x7f}) {
        std::string bad = frame;
        bad[i] = static_cast<char>(static_cast<unsigned char>(bad[i]) ^ x);
        const Decoded d = dca::wire::decode_frame(bad);
        if (d.status == Decoded::Status::kError) {
          ++rejected;
          EXPECT_FALSE(d.error.empty());
        } else if (d.status == Decoded::Status::kMessage) {
          ++decoded;
          EXPECT_FALSE(d.message.type.empty());
          EXPECT_TRUE(d.message.payload.is_map());
          // Encodes again to a frame that decodes to the same bytes (NaN != NaN, so compare encodings).
          const std::string again = dca::wire::encode(d.message);
          EXPECT_EQ(dca::wire::encode(decode_one(again)), again);
        }
      }
    }
  }
  EXPECT_GT(rejected, 0u);
  EXPECT_GT(decoded, 0u);  // e.g. a changed character inside a string
}

// A seeded fuzz loop: random flips, insertions, deletions and splices of valid frames, plus random bytes.
TEST(WireTest, SeededFuzzLoopNeverCrashes) {
  std::mt19937_64 rng(20261122);
  const auto msgs = every_message_type();
  std::size_t outcomes[3] = {0, 0, 0};
  for (int iter = 0; iter < 30000; ++iter) {
    std::string f = dca::wire::encode(msgs[rng() % msgs.size()]);
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits; ++e) {
      const std::size_t pos = f.empty() ? 0 : rng() % f.size();
      switch (rng() % 5) {
        case 0:
          if (!f.empty()) f[pos] = static_cast<char>(rng());
          break;
        case 1:
          f.insert(f.begin() + static_cast<std::ptrdiff_t>(pos), static_cast<char>(rng()));
          break;
        case 2:
          if (!f.empty()) f.erase(pos, 1);
          break;
        case 3:
          f.resize(pos);
          break;
        default: {
          // random bytes after the header
          f.resize(dca::wire::kHeaderSize + rng() % 64);
          for (std::size_t i = dca::wire::kHeaderSize; i < f.size(); ++i) f[i] = static_cast<char>(rng());
        }
      }
    }
    const Decoded d = dca::wire::decode_frame(f);
    ++outcomes[static_cast<int>(d.status)];
    if (d.status == Decoded::Status::kMessage) {
      EXPECT_LE(d.consumed, f.size());
      EXPECT_TRUE(d.message.payload.is_map());
    } else if (d.status == Decoded::Status::kError) {
      EXPECT_FALSE(d.error.empty());
    }
    // The body alone, whatever it is, must never read past its end.
    if (f.size() > dca::wire::kHeaderSize) {
      const Decoded b = dca::wire::decode_body(std::string_view(f).substr(dca::wire::kHeaderSize));
      EXPECT_NE(b.status, Decoded::Status::kNeedMore);
    }
  }
  EXPECT_GT(outcomes[static_cast<int>(Decoded::Status::kError)], 1000u);
}


TEST(WireTest, RejectsBodiesOfTheWrongShape) {
  struct Case {
    std::string body;
    const char* why;
  };
  const std::vector<Case> cases = {
      {B("\x93\xa2hi\x01"), "truncated"},                              // array of 3 with 2 items
      {B("\x92\xa2hi\x01"), "not an array [type, id, payload]"},        // array of 2
      {B("\xa2hi"), "not an array"},                                    // a string
      {B("\x93\x01\x01\x80"), "type is not a string"},                 // type 1
      {B("\x93\xa0\x01\x80"), "type is not a string of 1 to 64"},      // empty type
      {B("\x93\xa2hi\xff\x80"), "id is not an unsigned"},              // id -1
      {B("\x93\xa2hi\x01\x90"), "payload is not a map"},              // payload []
      {B("\x93\xa2hi\x01\x80\x00"), "trailing bytes"},                 // one byte too many
      {B("\x93\xa2hi\x01\x81\xa1x\xd4\x01\x02"), "ext"},              // fixext1
      // (a uint64 above INT64_MAX reads as a double: DoublesBeyondInt64RoundTrip...)
      {B("\x93\xa2hi\x01\x81\xa1x\xdd\xff\xff\xff\xff"), "malformed"},  // array of 4G items
      {B("\xc1"), "malformed"},                                          // never-used byte
  };
  for (const auto& c : cases) {
    const Decoded d = dca::wire::decode_body(c.body);
    EXPECT_EQ(d.status, Decoded::Status::kError) << c.why;
    EXPECT_NE(d.error.find(c.why), std::string::npos) << "expected '" << c.why << "', got: " << d.error;
  }
}

TEST(WireTest, NestingIsBounded) {
  // The deepest value the encoder accepts decodes; one level more is refused by both sides.
  Value v = 1;
  for (int i = 1; i < dca::wire::kMaxDepth; ++i) v = Value::Array{v};
  Message ok{"deep", 1, Value::map().set("v", v)};
  std::string frame;
  ASSERT_TRUE(dca::wire::encode(ok, frame));
  EXPECT_EQ(decode_one(frame), ok);
  Message too{"deep", 1, Value::map().set("v", Value::Array{v})};
  std::string out, error;
  EXPECT_FALSE(dca::wire::encode(too, out, &error));
  EXPECT_TRUE(out.empty());
  // A hand-made body nested 100 deep is rejected by the decoder.
  std::string body("\x93\xa2hi\x01\x81\xa1x", 8);
  body += std::string(100, '\x91');
  body += '\x01';
  const Decoded d = dca::wire::decode_body(body);
  EXPECT_EQ(d.status, Decoded::Status::kError);
}

TEST(WireTest, ValueAccessorsAndRendering) {
  Value v = Value::map();
  v.set("a", 1).set("b", "two").set("a", 3);
  EXPECT_EQ(v["a"].as_int(), 3);
  EXPECT_EQ(v["b"].as_string(), "two");
  EXPECT_TRUE(v["missing"].is_nil());
  EXPECT_EQ(v.find("missing"), nullptr);
  EXPECT_EQ(v.str(), "{a = 3, b = \"two\"}");
  EXPECT_EQ(Value(2.5).as_int(), 2);
  EXPECT_EQ(Value(2).as_float(), 2.0);
  const auto err = dca::wire::make_error(Message{"spawn", 5, Value::map()}, "not allowed");
  EXPECT_EQ(err.type, "error");
  EXPECT_EQ(err.id, 5u);
  EXPECT_EQ(err.payload["reason"].as_string(), "not allowed");
}

}  // namespace
