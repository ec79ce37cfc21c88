// dca::msgs (sdk/include/dca/msgs*.h): the type hashes against REP-2016 and the published values, the CDR bytes of
// known messages, round trips, and the decoder's refusals (short input, bad lengths, oversized sequences).
#include <dca/msgs.h>
#include <dca/msgs_cdr.h>
#include <dca/msgs_describe.h>
#include <gtest/gtest.h>
#include <openssl/sha.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "samples.h"

namespace dca::msgs {
namespace {

std::string rihs01(const std::string& json) {
  unsigned char d[SHA256_DIGEST_LENGTH];
  SHA256(reinterpret_cast<const unsigned char*>(json.data()), json.size(), d);
  std::string out = "RIHS01_";
  for (unsigned char c : d) {
    char h[3];
    std::snprintf(h, sizeof h, "%02x", c);
    out += h;
  }
  return out;
}

std::vector<std::byte> bytes(std::initializer_list<int> v) {
  std::vector<std::byte> out;
  for (int b : v) out.push_back(std::byte(b));
  return out;
}

template <class M>
std::vector<std::byte> encode(const M& m) {
  std::vector<std::byte> out(cdr_max_size<M>);
  out.resize(cdr_encode(m, out));
  return out;
}

TEST(Msgs, TypeHashesAreSha256OfTheTypeDescription) {
  for_each_message_type([]<class M>() { EXPECT_EQ(rihs01(type_description_json<M>()), M::type_hash) << M::ros_name; });
}

// Published: the hashes ROS 2 (Iron, Jazzy) generates for these types, as `ros2 topic info -v` prints them (Twist,
// TFMessage) and as independent REP-2016 implementations check them against the type description JSON that
// Jazzy's packages install (/opt/ros/jazzy/share/<pkg>/msg/<T>.json). Every one of dca's types is among them.
TEST(Msgs, TypeHashesEqualThePublishedOnes) {
  EXPECT_EQ(Time::type_hash, "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197");
  EXPECT_EQ(Header::type_hash, "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01");
  EXPECT_EQ(Vector3::type_hash, "RIHS01_cc12fe83e4c02719f1ce8070bfd14aecd40f75a96696a67a2a1f37f7dbb0765d");
  EXPECT_EQ(Point::type_hash, "RIHS01_6963084842a9b04494d6b2941d11444708d892da2f4b09843b9c43f42a7f6881");
  EXPECT_EQ(Quaternion::type_hash, "RIHS01_8a765f66778c8ff7c8ab94afcc590a2ed5325a1d9a076ffff38fbce36f458684");
  EXPECT_EQ(Twist::type_hash, "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a");
  EXPECT_EQ(Wrench::type_hash, "RIHS01_018e8519d57c16adbe97c9fe1460ef21fec7e31bc541de3d653a35895677ce52");
  EXPECT_EQ(WrenchStamped::type_hash, "RIHS01_8dc3deaf06b2ab281f9f9a742a8961c328ca7cec16e3fd6586d3a5c83fa78f77");
  EXPECT_EQ(Pose::type_hash, "RIHS01_d501954e9476cea2996984e812054b68026ae0bfae789d9a10b23daf35cc90fa");
  EXPECT_EQ(PoseStamped::type_hash, "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8");
  EXPECT_EQ(PoseWithCovariance::type_hash, "RIHS01_9a7c0fd234b7f45c6098745ecccd773ca1085670e64107135397aee31c02e1bb");
  EXPECT_EQ(TwistWithCovariance::type_hash, "RIHS01_49f574f033f095d8b6cd1beaca5ca7925e296e84af1716d16c89d38b059c8c18");
  EXPECT_EQ(Transform::type_hash, "RIHS01_beb83fbe698636351461f6f35d1abb20010c43d55374d81bd041f1ba2581fddc");
  EXPECT_EQ(TransformStamped::type_hash, "RIHS01_0a241f87d04668d94099cbb5ba11691d5ad32c2f29682e4eb5653424bd275206");
  EXPECT_EQ(JointState::type_hash, "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e");
  EXPECT_EQ(Odometry::type_hash, "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0");
  EXPECT_EQ(TFMessage::type_hash, "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087");
  EXPECT_EQ(MultiArrayDimension::type_hash, "RIHS01_5e773a60a4c7fc8a54985f307c7837aa2994252a126c301957a24e31282c9cbe");
  EXPECT_EQ(MultiArrayLayout::type_hash, "RIHS01_4c66e6f78e740ac103a94cf63259f968e48c617e7699e829b63c21a5cb50dac6");
  EXPECT_EQ(Float64MultiArray::type_hash, "RIHS01_1025ddc6b9552d191f89ef1a8d2f60f3d373e28b283d8891ddcc974e8c55397f");
}

TEST(Msgs, TypeDescriptionOfTime) {
  EXPECT_EQ(type_description_json<Time>(),
            "{\"type_description\": {\"type_name\": \"builtin_interfaces/msg/Time\", \"fields\": [{\"name\": \"sec\", "
            "\"type\": {\"type_id\": 6, \"capacity\": 0, \"string_capacity\": 0, \"nested_type_name\": \"\"}}, "
            "{\"name\": \"nanosec\", \"type\": {\"type_id\": 7, \"capacity\": 0, \"string_capacity\": 0, "
            "\"nested_type_name\": \"\"}}]}, \"referenced_type_descriptions\": []}");
}

// As ros2 bag writes them (rosbag2's local message definition source, docs/message_definition_encoding.md):
// dependencies depth first, each once, after a blank line, 80 '=' and "MSG: pkg/T".
TEST(Msgs, Ros2msgDefinitionsListTheDependenciesAfterTheirDelimiter) {
  const std::string line = "\n" + std::string(80, '=') + "\nMSG: ";
  EXPECT_EQ(ros2msg_definition<Header>(),
            "builtin_interfaces/Time stamp\nstring frame_id\n" + line +
                "builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n");
  EXPECT_EQ(ros2msg_definition<Quaternion>(), "float64 x\nfloat64 y\nfloat64 z\nfloat64 w 1\n");
  EXPECT_EQ(ros2msg_definition<PoseStamped>(),
            "std_msgs/Header header\ngeometry_msgs/Pose pose\n" + line +
                "geometry_msgs/Pose\ngeometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n" + line +
                "geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n" + line +
                "geometry_msgs/Quaternion\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w 1\n" + line +
                "std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n" + line +
                "builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n");
  const std::string odom = ros2msg_definition<Odometry>();
  EXPECT_NE(odom.find(line + "geometry_msgs/PoseWithCovariance\ngeometry_msgs/Pose pose\nfloat64[36] covariance\n"),
            std::string::npos);
  EXPECT_NE(ros2msg_definition<JointState>().find("\nstring[] name\nfloat64[] position\n"), std::string::npos);
}

TEST(Msgs, Names) {
  EXPECT_EQ(JointState::ros_name, "sensor_msgs/msg/JointState");
  EXPECT_EQ(JointState::dds_name, "sensor_msgs::msg::dds_::JointState_");
  EXPECT_EQ(TFMessage::dds_name, "tf2_msgs::msg::dds_::TFMessage_");
}

TEST(Msgs, TimeAndHeaderBytes) {
  EXPECT_EQ(encode(Time{1, 2}), bytes({0, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0}));
  Header h{{1, 2}, {}};
  ASSERT_TRUE(h.frame_id.assign("ab"));
  EXPECT_EQ(encode(h), bytes({0, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0, 'a', 'b', 0}));
}

TEST(Msgs, DoublesAreAlignedFromAfterTheHeader) {
  WrenchStamped w;
  ASSERT_TRUE(w.header.frame_id.assign("a"));  // header: 4 + 4 + 4 + 2 = 14 bytes, then 2 of padding
  w.wrench.force.x = 1;
  const auto b = encode(w);
  ASSERT_EQ(b.size(), 4u + 16 + 48);
  EXPECT_EQ(b[18], std::byte{0});
  EXPECT_EQ(b[19], std::byte{0});
  EXPECT_EQ(b[27], std::byte{0x3f});  // 1.0 little endian: 00 .. 00 f0 3f
}

TEST(Msgs, EveryTypeRoundTripsWithinItsMaxSize) {
  for_each_message_type([]<class M>() {
    const M m = testing::sample<M>();
    const auto b = encode(m);
    EXPECT_EQ(b.size(), cdr_size(m)) << M::ros_name;
    EXPECT_LE(b.size(), cdr_max_size<M>) << M::ros_name;
    M back{};
    const CdrResult r = cdr_decode(b, back);
    EXPECT_TRUE(r) << M::ros_name << ": " << to_string(r.error) << " at " << r.offset;
    EXPECT_EQ(r.offset, b.size()) << M::ros_name;
    EXPECT_TRUE(back == m) << M::ros_name;
  });
}

TEST(Msgs, FullMessagesFitTheMaxSize) {
  JointState j;
  while (j.name.push_back(testing::name(std::string(kNameCapacity, 'j')))) {
  }
  ASSERT_TRUE(j.position.resize(kMaxJoints) && j.velocity.resize(kMaxJoints) && j.effort.resize(kMaxJoints));
  EXPECT_LE(cdr_size(j), cdr_max_size<JointState>);
  EXPECT_NE(encode(j).size(), 0u);
}

TEST(Msgs, EncodeRefusesASmallBuffer) {
  const JointState j = testing::sample<JointState>();
  std::vector<std::byte> out(cdr_size(j) - 1);
  EXPECT_EQ(cdr_encode(j, out), 0u);
  out.resize(cdr_size(j));
  EXPECT_EQ(cdr_encode(j, out), out.size());
}

TEST(Msgs, BoundedTypesRefuseMoreThanTheirCapacity) {
  Name n;
  EXPECT_TRUE(n.assign(std::string(kNameCapacity, 'x')));
  EXPECT_FALSE(n.assign(std::string(kNameCapacity + 1, 'y')));
  EXPECT_EQ(n.view(), std::string(kNameCapacity, 'x'));  // unchanged, not truncated
  EXPECT_FALSE(n.assign(std::string_view("a\0b", 3)));
  Seq<double, 2> s;
  EXPECT_TRUE(s.push_back(1) && s.push_back(2));
  EXPECT_FALSE(s.push_back(3));
  EXPECT_FALSE(s.resize(3));
  EXPECT_EQ(s.size(), 2u);
}

TEST(Msgs, DecodeRefusesEveryTruncation) {
  const auto b = encode(testing::sample<TFMessage>());
  for (std::size_t n = 0; n < b.size(); ++n) {
    TFMessage m;
    const CdrResult r = cdr_decode(std::span(b).first(n), m);
    EXPECT_EQ(r.error, CdrError::Short) << "prefix of " << n << " bytes";
    EXPECT_LE(r.offset, n);
  }
}

TEST(Msgs, DecodeRefusesOtherEncapsulations) {
  Time t;
  for (auto h : {bytes({0, 2, 0, 0}), bytes({0, 3, 0, 0}), bytes({0, 7, 0, 0}), bytes({1, 1, 0, 0})}) {
    h.resize(12);
    EXPECT_EQ(cdr_decode(h, t).error, CdrError::Encapsulation);
  }
}

TEST(Msgs, DecodeReadsBigEndian) {
  Time t;
  ASSERT_TRUE(cdr_decode(bytes({0, 0, 0, 0, 0xff, 0xff, 0xff, 0xfe, 0, 0, 0, 9}), t));
  EXPECT_EQ(t, (Time{-2, 9}));
}

TEST(Msgs, DecodeRefusesBadStrings) {
  Header h;
  // length 3 but no NUL at its end
  EXPECT_EQ(cdr_decode(bytes({0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 3, 0, 0, 0, 'a', 'b', 'c'}), h).error,
            CdrError::BadString);
  // a NUL inside
  EXPECT_EQ(cdr_decode(bytes({0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 3, 0, 0, 0, 'a', 0, 0}), h).error,
            CdrError::BadString);
  // a length past the input's end
  const CdrResult r = cdr_decode(bytes({0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff, 0xff, 0x0f, 'a', 0}), h);
  EXPECT_EQ(r.error, CdrError::TooLong);
  EXPECT_EQ(r.offset, 12u);
  EXPECT_EQ(cdr_decode(bytes({0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 5, 0, 0, 0, 'a', 0}), h).error, CdrError::Short);
  // an empty string without its NUL (length 0) is read as empty
  ASSERT_TRUE(cdr_decode(bytes({0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0}), h));
  EXPECT_TRUE(h.frame_id.empty());
}

TEST(Msgs, DecodeRefusesAStringLongerThanItsCapacity) {
  Header h;
  ASSERT_TRUE(h.frame_id.assign(std::string(kNameCapacity, 'f')));
  auto b = encode(h);
  Header back;
  ASSERT_TRUE(cdr_decode(b, back));
  b[12] = std::byte(kNameCapacity + 2);  // one more character than fits: refused, never cut short
  b.insert(b.end() - 1, std::byte{'g'});
  EXPECT_EQ(cdr_decode(b, back).error, CdrError::TooLong);
}

TEST(Msgs, DecodeRefusesOversizedSequences) {
  Float64MultiArray a;
  auto b = encode(a);  // no dims, data_offset 0, no data: 4 + 4 + 4 + 4
  ASSERT_EQ(b.size(), 16u);
  b[12] = std::byte((kMaxArrayData + 1) & 0xff);
  b[13] = std::byte((kMaxArrayData + 1) >> 8);
  b.resize(16 + 8 * (kMaxArrayData + 1) + 4);  // the bytes are there: the count alone is refused
  CdrResult r = cdr_decode(b, a);
  EXPECT_EQ(r.error, CdrError::TooLong);
  EXPECT_EQ(r.offset, 12u);
  b[12] = std::byte{0xff}, b[13] = std::byte{0xff}, b[14] = std::byte{0xff}, b[15] = std::byte{0xff};
  EXPECT_EQ(cdr_decode(b, a).error, CdrError::TooLong);
  JointState j;
  auto jb = encode(j);  // header (4 + 8 + 4 + 1), pad 3, then the names' count at 20
  jb[20] = std::byte(kMaxJoints + 1);
  EXPECT_EQ(cdr_decode(jb, j).error, CdrError::TooLong);
}

TEST(Msgs, ToJsonIsValidJsonWhateverTheValues) {
  Header h;
  ASSERT_TRUE(h.frame_id.assign("a\"\\\x01\xff\xc3\xa9\xed\xa0\x80"));  // quote, backslash, control, bad byte,
  EXPECT_EQ(to_json(h), "{\"stamp\":{\"sec\":0,\"nanosec\":0},\"frame_id\":"  // é, a surrogate
                        "\"a\\\"\\\\\\u0001\xef\xbf\xbd\xc3\xa9\xef\xbf\xbd\xef\xbf\xbd\xef\xbf\xbd\"}");
  EXPECT_EQ(to_json(Vector3{std::nan(""), HUGE_VAL, 1}), R"({"x":null,"y":null,"z":1})");
}

TEST(Msgs, ToJsonNamesTheFields) {
  EXPECT_EQ(to_json(testing::sample<Header>()), R"({"stamp":{"sec":7,"nanosec":250000000},"frame_id":"base_link"})");
  EXPECT_EQ(to_json(Vector3{0.5, -1, 2}), R"({"x":0.5,"y":-1,"z":2})");
}

}  // namespace
}  // namespace dca::msgs
