#pragma once
// One sample of every dca::msgs type, with every field set to a value of its own (exact binary doubles, strings of
// several lengths, sequences of several sizes): what the byte tests encode on both sides (tests/ros2).
#include <dca/msgs.h>

#include <string_view>

namespace dca::msgs::testing {

inline Header header(std::int32_t sec, std::string_view frame) {
  Header h;
  h.stamp = {sec, 250000000u};
  h.frame_id.assign(frame);
  return h;
}
inline Name name(std::string_view s) {
  Name n;
  n.assign(s);
  return n;
}
inline Quaternion quat() { return {0.5, -0.5, 0.5, -0.5}; }

/// The sample of M.
template <class M>
M sample();

template <> inline Time sample<Time>() { return {-2, 300000000u}; }
template <> inline Header sample<Header>() { return header(7, "base_link"); }
template <> inline Vector3 sample<Vector3>() { return {1.5, -2.25, 1e-300}; }
template <> inline Point sample<Point>() { return {0.125, 3, -1e10}; }
template <> inline Quaternion sample<Quaternion>() { return quat(); }
template <> inline Twist sample<Twist>() { return {{1, 2, 3}, {-0.25, 0, 0.75}}; }
template <> inline Wrench sample<Wrench>() { return {{10, -20, 30.5}, {0.001953125, 0, -4}}; }
template <> inline WrenchStamped sample<WrenchStamped>() { return {header(1, "tool0"), sample<Wrench>()}; }
template <> inline Pose sample<Pose>() { return {{1, 2, 3}, quat()}; }
template <> inline PoseStamped sample<PoseStamped>() { return {header(3, "map"), sample<Pose>()}; }
template <> inline Transform sample<Transform>() { return {{0.5, 0, -0.5}, quat()}; }
template <> inline PoseWithCovariance sample<PoseWithCovariance>() {
  PoseWithCovariance p{sample<Pose>(), {}};
  for (std::size_t i = 0; i < 36; ++i) p.covariance[i] = 0.5 * static_cast<double>(i) - 4;
  return p;
}
template <> inline TwistWithCovariance sample<TwistWithCovariance>() {
  TwistWithCovariance t{sample<Twist>(), {}};
  for (std::size_t i = 0; i < 36; i += 7) t.covariance[i] = 0.01;
  return t;
}
template <> inline TransformStamped sample<TransformStamped>() {
  TransformStamped t{header(5, "world"), {}, sample<Transform>()};
  t.child_frame_id.assign("a");
  return t;
}
template <> inline JointState sample<JointState>() {
  JointState j;
  j.header = header(11, "");
  for (std::string_view n : {"shoulder_pan_joint", "elbow", "w"}) j.name.push_back(name(n));
  for (double x : {0.5, -1.25, 3.0}) j.position.push_back(x);
  for (double x : {0.0, 0.125, -2.0}) j.velocity.push_back(x);
  return j;  // no efforts: an empty sequence
}
template <> inline Odometry sample<Odometry>() {
  Odometry o{header(13, "odom"), {}, sample<PoseWithCovariance>(), sample<TwistWithCovariance>()};
  o.child_frame_id.assign("base_footprint");
  return o;
}
template <> inline TFMessage sample<TFMessage>() {
  TFMessage m;
  m.transforms.push_back(sample<TransformStamped>());
  TransformStamped t = sample<TransformStamped>();
  t.header.frame_id.assign("base_link");
  t.child_frame_id.assign("upper_arm_link");
  t.transform.translation.z = 0.1273;
  m.transforms.push_back(t);
  return m;
}
template <> inline MultiArrayDimension sample<MultiArrayDimension>() {
  MultiArrayDimension d{{}, 3, 6};
  d.label.assign("rows");
  return d;
}
template <> inline MultiArrayLayout sample<MultiArrayLayout>() {
  MultiArrayLayout l;
  l.dim.push_back(sample<MultiArrayDimension>());
  MultiArrayDimension c{{}, 2, 2};
  c.label.assign("cols");
  l.dim.push_back(c);
  l.data_offset = 1;
  return l;
}
template <> inline Float64MultiArray sample<Float64MultiArray>() {
  Float64MultiArray a{sample<MultiArrayLayout>(), {}};
  for (int i = 0; i < 7; ++i) a.data.push_back(i * 0.75 - 1);
  return a;
}

}  // namespace dca::msgs::testing
