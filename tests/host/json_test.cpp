// json: values out and back, escapes, and refusals of what is not JSON (never a crash, bounded depth).
#include "host/codec/json.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

namespace {

using dca::wire::Value;

TEST(JsonTest, EncodesValuesAndDecodesThemBack) {
  Value v = Value::map();
  v.set("type", "tree").set("n", 3).set("x", 0.25).set("ok", true).set("none", Value());
  v.set("list", Value(Value::Array{Value(1), Value("a\"b\\c\n"), Value(Value::Array{})}));
  const std::string text = dca::json::encode(v);
  EXPECT_EQ(text, R"({"type":"tree","n":3,"x":0.25,"ok":true,"none":null,"list":[1,"a\"b\\c\u000a",[]]})");
  Value back;
  std::string error;
  ASSERT_TRUE(dca::json::decode(text, &back, &error)) << error;
  EXPECT_EQ(back["type"].as_string(), "tree");
  EXPECT_EQ(back["n"].as_int(), 3);
  EXPECT_DOUBLE_EQ(back["x"].as_float(), 0.25);
  EXPECT_EQ(back["list"].as_array()[1].as_string(), "a\"b\\c\n");
}

TEST(JsonTest, MinusZeroKeepsItsSign) {  // a world's -0 recorded, read and recorded again is -0 (a replay)
  Value v;
  ASSERT_TRUE(dca::json::decode("[-0,0,-0.0]", &v, nullptr));
  EXPECT_TRUE(v.as_array()[0].is_float());
  EXPECT_TRUE(std::signbit(v.as_array()[0].as_float()));
  EXPECT_TRUE(v.as_array()[1].is_int());
  EXPECT_EQ(dca::json::encode(v), "[-0,0,-0]");
}

TEST(JsonTest, NonFiniteNumbersAndBadUtf8AreStillJson) {
  EXPECT_EQ(dca::json::encode(Value(std::numeric_limits<double>::quiet_NaN())), "null");
  EXPECT_EQ(dca::json::encode(Value(std::string("\xff""a"))), "\"\xef\xbf\xbd""a\"");
  EXPECT_EQ(dca::json::encode(Value(std::string("\xc3\xa9"))), "\"\xc3\xa9\"");
  Value v;
  ASSERT_TRUE(dca::json::decode(R"("\u00e9\ud83d\ude00")", &v, nullptr));
  EXPECT_EQ(v.as_string(), "\xc3\xa9\xf0\x9f\x98\x80");
}

// Whatever goes in, valid UTF-8 comes out: a byte that starts no valid sequence (a stray continuation, a
// truncated sequence, an overlong form, a surrogate, past U+10FFFF) is U+FFFD, each escaped surrogate not in a
// pair is U+FFFD, and the escape after a lone high surrogate is still read.
TEST(JsonTest, InvalidUtf8AndLoneSurrogatesBecomeTheReplacementCharacter) {
  const std::string r = "\xef\xbf\xbd";  // U+FFFD
  const auto enc = [](const std::string& s) { return dca::json::encode(Value(s)); };
  EXPECT_EQ(enc("a\x80""b"), "\"a" + r + "b\"");
  EXPECT_EQ(enc("\xc0\xaf"), "\"" + r + r + "\"") << "overlong '/'";
  EXPECT_EQ(enc("\xe0\x80\xaf"), "\"" + r + r + r + "\"") << "overlong, 3 bytes";
  EXPECT_EQ(enc("\xed\xa0\x80"), "\"" + r + r + r + "\"") << "the surrogate U+D800 in UTF-8";
  EXPECT_EQ(enc("\xf4\x90\x80\x80"), "\"" + r + r + r + r + "\"") << "U+110000";
  EXPECT_EQ(enc("\xe2\x82"), "\"" + r + r + "\"") << "truncated";
  EXPECT_EQ(enc("\xed\x9f\xbf\xf4\x8f\xbf\xbf"), "\"\xed\x9f\xbf\xf4\x8f\xbf\xbf\"") << "U+D7FF, U+10FFFF";

  const auto dec = [](const std::string& text) {
    Value v;
    std::string error;
    EXPECT_TRUE(dca::json::decode(text, &v, &error)) << text << ": " << error;
    return v.is_string() ? v.as_string() : std::string("(not a string)");
  };
  EXPECT_EQ(dec(R"("\ud800")"), r) << "a lone high surrogate";
  EXPECT_EQ(dec(R"("\udc00x")"), r + "x") << "a lone low surrogate";
  EXPECT_EQ(dec(R"("\ud800\u0041")"), r + "A") << "a high surrogate before another escape: both read";
  EXPECT_EQ(dec(R"("\ud800\ud83d\ude00")"), r + "\xf0\x9f\x98\x80") << "a high one, then a pair";
  EXPECT_EQ(dec("\"\xed\xa0\x80\xff\xc3\xa9\""), r + r + r + r + "\xc3\xa9") << "raw bad bytes";
  Value v;
  EXPECT_FALSE(dca::json::decode(R"("\ud800\u00")", &v, nullptr)) << "a short second escape is still refused";
}

TEST(JsonTest, RefusesWhatIsNotJsonWithTheOffset) {
  Value v;
  std::string error;
  for (const char* bad : {"", "{", "[1,]", "{\"a\" 1}", "tru", "\"abc", "1 2", "{1:2}", "[1e]", "-", "\"\\x\""}) {
    EXPECT_FALSE(dca::json::decode(bad, &v, &error)) << bad;
    EXPECT_EQ(error.rfind("offset ", 0), 0u) << bad << ": " << error;
  }
  EXPECT_FALSE(dca::json::decode(std::string(100000, '['), &v, &error));
  EXPECT_NE(error.find("nested too deep"), std::string::npos) << error;
}

TEST(JsonTest, RandomBytesNeverCrashTheDecoder) {
  std::mt19937 rng(11);
  const std::string alphabet = "{}[]\",:0123456789.eE+-truefalsnl \\u";
  int accepted = 0;
  for (int i = 0; i < 20000; i++) {
    std::string s(rng() % 40, ' ');
    for (auto& c : s) c = (rng() % 4 == 0) ? static_cast<char>(rng()) : alphabet[rng() % alphabet.size()];
    Value v;
    if (dca::json::decode(s, &v, nullptr)) {
      accepted++;
      Value again;
      EXPECT_TRUE(dca::json::decode(dca::json::encode(v), &again, nullptr)) << s;
      EXPECT_EQ(dca::json::encode(again), dca::json::encode(v)) << s;  // valid UTF-8 goes through unchanged
    }
  }
  EXPECT_GT(accepted, 0);
}

}  // namespace
