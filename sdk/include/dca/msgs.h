#pragma once
// dca::msgs: typed messages shaped like ROS 2's (docs/data-plane.md, "Typed messages"). Each is a plain struct of
// fixed layout (trivially copyable, no heap): strings and sequences have a bounded capacity inline, and anything
// longer is refused where it enters (String::assign, Seq::push_back/resize, cdr_decode), never cut short.
//
//   bound                          capacity   used by
//   kNameCapacity                  63 chars   Header::frame_id, child_frame_id, JointState names
//   kMaxJoints                     32         JointState::{name, position, velocity, effort}
//   kMaxTransforms                 32         TFMessage::transforms
//   kMaxArrayDims / kLabelCapacity 4 / 31     MultiArrayLayout::dim, MultiArrayDimension::label
//   kMaxArrayData                  256        Float64MultiArray::data
//
// Every message type M has
//   M::ros_name    "sensor_msgs/msg/JointState"            (ROS 2's interface name)
//   M::dds_name    "sensor_msgs::msg::dds_::JointState_"   (the DDS type name ROS 2 uses on the wire)
//   M::type_hash   "RIHS01_<64 hex>"                       (REP-2016: sha256 of the type description's JSON)
//   M::fields(m, f)  calls f(name, member) for each field in ROS order (m may be const): what the codecs
//                    (dca/msgs_cdr.h) and descriptions (dca/msgs_describe.h) walk.
// The ROS type of a field follows from its C++ type: double float64, std::int32_t int32, std::uint32_t uint32,
// String<N> string, std::array<T, N> T[N], Seq<T, N> T[] (unbounded in ROS: the bound is dca's), M a nested type.
// Only std here: a controller package includes it as it is.
#include <array>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string_view>
#include <type_traits>

namespace dca::msgs {

inline constexpr std::size_t kNameCapacity = 63;
inline constexpr std::size_t kMaxJoints = 32;
inline constexpr std::size_t kMaxTransforms = 32;
inline constexpr std::size_t kMaxArrayDims = 4;
inline constexpr std::size_t kLabelCapacity = 31;
inline constexpr std::size_t kMaxArrayData = 256;

/// A string of at most N bytes, stored inline with a terminating NUL. Never holds a NUL inside (CDR could not
/// carry it).
template <std::size_t N>
class String {
 public:
  static constexpr std::size_t capacity = N;
  constexpr String() = default;
  /// Copies `s`: false (and unchanged) when it is longer than N or holds a NUL.
  constexpr bool assign(std::string_view s) {
    if (s.size() > N || s.find('\0') != std::string_view::npos) return false;
    for (std::size_t i = 0; i < s.size(); ++i) data_[i] = s[i];
    data_[s.size()] = '\0';
    size_ = static_cast<std::uint32_t>(s.size());
    return true;
  }
  constexpr std::string_view view() const { return {data_.data(), size_}; }
  constexpr const char* c_str() const { return data_.data(); }
  constexpr std::size_t size() const { return size_; }
  constexpr bool empty() const { return size_ == 0; }
  friend constexpr bool operator==(const String& a, const String& b) { return a.view() == b.view(); }

 private:
  std::array<char, N + 1> data_{};
  std::uint32_t size_ = 0;
};

/// A sequence of at most N elements, stored inline.
template <class T, std::size_t N>
class Seq {
 public:
  using value_type = T;
  static constexpr std::size_t capacity = N;
  constexpr Seq() = default;
  /// Appends `v`: false (and unchanged) when full.
  constexpr bool push_back(const T& v) {
    if (size_ == N) return false;
    items_[size_++] = v;
    return true;
  }
  /// Sets the size to `n` (new elements are T{}): false (and unchanged) when n > N.
  constexpr bool resize(std::size_t n) {
    if (n > N) return false;
    for (std::size_t i = size_; i < n; ++i) items_[i] = T{};
    size_ = static_cast<std::uint32_t>(n);
    return true;
  }
  constexpr void clear() { size_ = 0; }
  constexpr std::size_t size() const { return size_; }
  constexpr bool empty() const { return size_ == 0; }
  constexpr T& operator[](std::size_t i) { return items_[i]; }
  constexpr const T& operator[](std::size_t i) const { return items_[i]; }
  constexpr T* begin() { return items_.data(); }
  constexpr T* end() { return items_.data() + size_; }
  constexpr const T* begin() const { return items_.data(); }
  constexpr const T* end() const { return items_.data() + size_; }
  friend constexpr bool operator==(const Seq& a, const Seq& b) {
    if (a.size_ != b.size_) return false;
    for (std::size_t i = 0; i < a.size_; ++i)
      if (!(a.items_[i] == b.items_[i])) return false;
    return true;
  }

 private:
  std::array<T, N> items_{};
  std::uint32_t size_ = 0;
};

using Name = String<kNameCapacity>;

/// A message type: a struct with ros_name, dds_name, type_hash and fields() (see the header comment).
template <class M>
concept Message = requires {
  { M::ros_name } -> std::convertible_to<std::string_view>;
  { M::dds_name } -> std::convertible_to<std::string_view>;
  { M::type_hash } -> std::convertible_to<std::string_view>;
};

// The names of one type, in one line each below.
#define DCA_MSGS_NAMES(PKG, T, HASH)                                   \
  static constexpr std::string_view ros_name = PKG "/msg/" #T;         \
  static constexpr std::string_view dds_name = PKG "::msg::dds_::" #T "_"; \
  static constexpr std::string_view type_hash = "RIHS01_" HASH;

/// builtin_interfaces/msg/Time: seconds and nanoseconds (simulated or wall time).
struct Time {
  DCA_MSGS_NAMES("builtin_interfaces", Time, "b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197")
  std::int32_t sec = 0;
  std::uint32_t nanosec = 0;
  template <class M, class F>
  static constexpr void fields(M& m, F&& f) {
    f("sec", m.sec);
    f("nanosec", m.nanosec);
  }
  friend constexpr bool operator==(const Time&, const Time&) = default;
};

/// std_msgs/msg/Header: a stamp and the frame the data is in.
struct Header {
  DCA_MSGS_NAMES("std_msgs", Header, "f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01")
  Time stamp;
  Name frame_id;
  template <class M, class F>
  static constexpr void fields(M& m, F&& f) {
    f("stamp", m.stamp);
    f("frame_id", m.frame_id);
  }
  friend constexpr bool operator==(const Header&, const Header&) = default;
};

// geometry_msgs/msg/{Vector3, Point}: three doubles.
#define DCA_MSGS_XYZ(T, HASH)                          \
  struct T {                                           \
    DCA_MSGS_NAMES("geometry_msgs", T, HASH)           \
    double x = 0, y = 0, z = 0;                        \
    template <class M, class F>                        \
    static constexpr void fields(M& m, F&& f) {        \
      f("x", m.x);                                     \
      f("y", m.y);                                     \
      f("z", m.z);                                     \
    }                                                  \
    friend constexpr bool operator==(const T&, const T&) = default; \
  };
DCA_MSGS_XYZ(Vector3, "cc12fe83e4c02719f1ce8070bfd14aecd40f75a96696a67a2a1f37f7dbb0765d")
DCA_MSGS_XYZ(Point, "6963084842a9b04494d6b2941d11444708d892da2f4b09843b9c43f42a7f6881")
#undef DCA_MSGS_XYZ

/// geometry_msgs/msg/Quaternion: x, y, z, w (the identity by default, as in ROS).
struct Quaternion {
  DCA_MSGS_NAMES("geometry_msgs", Quaternion, "8a765f66778c8ff7c8ab94afcc590a2ed5325a1d9a076ffff38fbce36f458684")
  double x = 0, y = 0, z = 0, w = 1;
  template <class M, class F>
  static constexpr void fields(M& m, F&& f) {
    f("x", m.x);
    f("y", m.y);
    f("z", m.z);
    f("w", m.w);
  }
  friend constexpr bool operator==(const Quaternion&, const Quaternion&) = default;
};

// A message of two fields A a; B b; (Twist, Wrench, Pose, Transform, ...).
#define DCA_MSGS_PAIR(PKG, T, HASH, A, a, B, b)      \
  struct T {                                         \
    DCA_MSGS_NAMES(PKG, T, HASH)                     \
    A a{};                                           \
    B b{};                                           \
    template <class M, class F>                      \
    static constexpr void fields(M& m, F&& f) {      \
      f(#a, m.a);                                    \
      f(#b, m.b);                                    \
    }                                                \
    friend constexpr bool operator==(const T&, const T&) = default; \
  };

/// geometry_msgs/msg/Twist: linear and angular velocity.
DCA_MSGS_PAIR("geometry_msgs", Twist, "9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a",
              Vector3, linear, Vector3, angular)
/// geometry_msgs/msg/Wrench: force and torque.
DCA_MSGS_PAIR("geometry_msgs", Wrench, "018e8519d57c16adbe97c9fe1460ef21fec7e31bc541de3d653a35895677ce52",
              Vector3, force, Vector3, torque)
/// geometry_msgs/msg/Pose: position and orientation.
DCA_MSGS_PAIR("geometry_msgs", Pose, "d501954e9476cea2996984e812054b68026ae0bfae789d9a10b23daf35cc90fa",
              Point, position, Quaternion, orientation)
/// geometry_msgs/msg/Transform: translation and rotation.
DCA_MSGS_PAIR("geometry_msgs", Transform, "beb83fbe698636351461f6f35d1abb20010c43d55374d81bd041f1ba2581fddc",
              Vector3, translation, Quaternion, rotation)
/// geometry_msgs/msg/WrenchStamped.
DCA_MSGS_PAIR("geometry_msgs", WrenchStamped, "8dc3deaf06b2ab281f9f9a742a8961c328ca7cec16e3fd6586d3a5c83fa78f77",
              Header, header, Wrench, wrench)
/// geometry_msgs/msg/PoseStamped.
DCA_MSGS_PAIR("geometry_msgs", PoseStamped, "10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8",
              Header, header, Pose, pose)

/// A 6x6 covariance, row-major.
using Covariance = std::array<double, 36>;

/// geometry_msgs/msg/PoseWithCovariance: a pose and its 6x6 covariance, row-major (x, y, z, rotation about x, y, z).
DCA_MSGS_PAIR("geometry_msgs", PoseWithCovariance, "9a7c0fd234b7f45c6098745ecccd773ca1085670e64107135397aee31c02e1bb",
              Pose, pose, Covariance, covariance)

/// geometry_msgs/msg/TwistWithCovariance: a twist and its 6x6 covariance, row-major.
DCA_MSGS_PAIR("geometry_msgs", TwistWithCovariance, "49f574f033f095d8b6cd1beaca5ca7925e296e84af1716d16c89d38b059c8c18",
              Twist, twist, Covariance, covariance)

/// geometry_msgs/msg/TransformStamped: the transform of child_frame_id in header.frame_id.
struct TransformStamped {
  DCA_MSGS_NAMES("geometry_msgs", TransformStamped,
                 "0a241f87d04668d94099cbb5ba11691d5ad32c2f29682e4eb5653424bd275206")
  Header header;
  Name child_frame_id;
  Transform transform;
  template <class M, class F>
  static constexpr void fields(M& m, F&& f) {
    f("header", m.header);
    f("child_frame_id", m.child_frame_id);
    f("transform", m.transform);
  }
  friend constexpr bool operator==(const TransformStamped&, const TransformStamped&) = default;
};

/// sensor_msgs/msg/JointState: up to kMaxJoints joints by name; position, velocity and effort each empty or of
/// the size of name (ROS's rule; not checked here).
struct JointState {
  DCA_MSGS_NAMES("sensor_msgs", JointState, "a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e")
  Header header;
  Seq<Name, kMaxJoints> name;
  Seq<double, kMaxJoints> position, velocity, effort;
  template <class M, class F>
  static constexpr void fields(M& m, F&& f) {
    f("header", m.header);
    f("name", m.name);
    f("position", m.position);
    f("velocity", m.velocity);
    f("effort", m.effort);
  }
  friend constexpr bool operator==(const JointState&, const JointState&) = default;
};

/// nav_msgs/msg/Odometry: the pose in header.frame_id, the twist in child_frame_id.
struct Odometry {
  DCA_MSGS_NAMES("nav_msgs", Odometry, "3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0")
  Header header;
  Name child_frame_id;
  PoseWithCovariance pose;
  TwistWithCovariance twist;
  template <class M, class F>
  static constexpr void fields(M& m, F&& f) {
    f("header", m.header);
    f("child_frame_id", m.child_frame_id);
    f("pose", m.pose);
    f("twist", m.twist);
  }
  friend constexpr bool operator==(const Odometry&, const Odometry&) = default;
};

/// tf2_msgs/msg/TFMessage: up to kMaxTransforms transforms (what /tf and /tf_static carry).
struct TFMessage {
  DCA_MSGS_NAMES("tf2_msgs", TFMessage, "e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087")
  Seq<TransformStamped, kMaxTransforms> transforms;
  template <class M, class F>
  static constexpr void fields(M& m, F&& f) {
    f("transforms", m.transforms);
  }
  friend constexpr bool operator==(const TFMessage&, const TFMessage&) = default;
};

/// std_msgs/msg/MultiArrayDimension: a label, the dimension's size and its stride.
struct MultiArrayDimension {
  DCA_MSGS_NAMES("std_msgs", MultiArrayDimension, "5e773a60a4c7fc8a54985f307c7837aa2994252a126c301957a24e31282c9cbe")
  String<kLabelCapacity> label;
  std::uint32_t size = 0;
  std::uint32_t stride = 0;
  template <class M, class F>
  static constexpr void fields(M& m, F&& f) {
    f("label", m.label);
    f("size", m.size);
    f("stride", m.stride);
  }
  friend constexpr bool operator==(const MultiArrayDimension&, const MultiArrayDimension&) = default;
};

/// std_msgs/msg/MultiArrayLayout.
using MultiArrayDims = Seq<MultiArrayDimension, kMaxArrayDims>;
DCA_MSGS_PAIR("std_msgs", MultiArrayLayout, "4c66e6f78e740ac103a94cf63259f968e48c617e7699e829b63c21a5cb50dac6",
              MultiArrayDims, dim, std::uint32_t, data_offset)

/// std_msgs/msg/Float64MultiArray: up to kMaxArrayData doubles and their layout.
struct Float64MultiArray {
  DCA_MSGS_NAMES("std_msgs", Float64MultiArray, "1025ddc6b9552d191f89ef1a8d2f60f3d373e28b283d8891ddcc974e8c55397f")
  MultiArrayLayout layout;
  Seq<double, kMaxArrayData> data;
  template <class M, class F>
  static constexpr void fields(M& m, F&& f) {
    f("layout", m.layout);
    f("data", m.data);
  }
  friend constexpr bool operator==(const Float64MultiArray&, const Float64MultiArray&) = default;
};

#undef DCA_MSGS_PAIR
#undef DCA_MSGS_NAMES

/// What a field's C++ type is, for the walks over fields (the codecs, the descriptions).
namespace detail {
template <class T>
struct IsString : std::false_type {};
template <std::size_t N>
struct IsString<String<N>> : std::true_type {};
template <class T>
struct IsSeq : std::false_type {};
template <class T, std::size_t N>
struct IsSeq<Seq<T, N>> : std::true_type {};
template <class T>
struct IsArray : std::false_type {};
template <class T, std::size_t N>
struct IsArray<std::array<T, N>> : std::true_type {};
/// A primitive field: the arithmetic types ROS has (no long double, no char: int8 and uint8 are the bytes).
template <class T>
concept Primitive = std::is_arithmetic_v<T> && !std::is_same_v<T, long double>;
}  // namespace detail

/// Calls f.template operator()<M>() for every message type, in one fixed order.
template <class F>
constexpr void for_each_message_type(F&& f) {
  f.template operator()<Time>();
  f.template operator()<Header>();
  f.template operator()<Vector3>();
  f.template operator()<Point>();
  f.template operator()<Quaternion>();
  f.template operator()<Twist>();
  f.template operator()<Wrench>();
  f.template operator()<WrenchStamped>();
  f.template operator()<Pose>();
  f.template operator()<PoseStamped>();
  f.template operator()<PoseWithCovariance>();
  f.template operator()<TwistWithCovariance>();
  f.template operator()<Transform>();
  f.template operator()<TransformStamped>();
  f.template operator()<JointState>();
  f.template operator()<Odometry>();
  f.template operator()<TFMessage>();
  f.template operator()<MultiArrayDimension>();
  f.template operator()<MultiArrayLayout>();
  f.template operator()<Float64MultiArray>();
}

}  // namespace dca::msgs
