#pragma once
// The ROS 2 graph's messages (docs/ros2.md, "The graph"): rmw_dds_common/msg/ParticipantEntitiesInfo, what every
// ROS 2 participant publishes on the DDS topic `ros_discovery_info` (RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1) so that
// `ros2 node list` and `ros2 topic info` know its nodes and which writers and readers are theirs. Shaped like the
// messages of dca/msgs.h, so that dca/msgs_cdr.h encodes and decodes them. As in ROS 2 Iron and later, a GID is
// the entity's 16-byte DDS GUID.
#include <array>
#include <cstdint>
#include <string_view>

#include <dca/msgs.h>

namespace dca::ros2 {

/// The most writers (or readers) one node lists: every slot of the bridge and more.
inline constexpr std::size_t kMaxGraphEndpoints = 64;

/// rmw_dds_common/msg/Gid: uint8[16] data.
struct GidMsg {
  static constexpr std::string_view ros_name = "rmw_dds_common/msg/Gid";
  static constexpr std::string_view dds_name = "rmw_dds_common::msg::dds_::Gid_";
  static constexpr std::string_view type_hash = "";
  std::array<std::uint8_t, 16> data{};
  template <class M, class F>
  static constexpr void fields(M& m, F&& f) {
    f("data", m.data);
  }
  friend constexpr bool operator==(const GidMsg&, const GidMsg&) = default;
};

/// rmw_dds_common/msg/NodeEntitiesInfo: a node's namespace and name (string<=256 each) and its endpoints.
struct NodeEntitiesInfo {
  static constexpr std::string_view ros_name = "rmw_dds_common/msg/NodeEntitiesInfo";
  static constexpr std::string_view dds_name = "rmw_dds_common::msg::dds_::NodeEntitiesInfo_";
  static constexpr std::string_view type_hash = "";
  msgs::String<256> node_namespace;
  msgs::String<256> node_name;
  msgs::Seq<GidMsg, kMaxGraphEndpoints> reader_gid_seq;
  msgs::Seq<GidMsg, kMaxGraphEndpoints> writer_gid_seq;
  template <class M, class F>
  static constexpr void fields(M& m, F&& f) {
    f("node_namespace", m.node_namespace);
    f("node_name", m.node_name);
    f("reader_gid_seq", m.reader_gid_seq);
    f("writer_gid_seq", m.writer_gid_seq);
  }
  friend constexpr bool operator==(const NodeEntitiesInfo&, const NodeEntitiesInfo&) = default;
};

/// rmw_dds_common/msg/ParticipantEntitiesInfo: the participant's GID and its nodes (the bridge has one).
struct ParticipantEntitiesInfo {
  static constexpr std::string_view ros_name = "rmw_dds_common/msg/ParticipantEntitiesInfo";
  static constexpr std::string_view dds_name = "rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_";
  static constexpr std::string_view type_hash = "";
  GidMsg gid;
  msgs::Seq<NodeEntitiesInfo, 4> node_entities_info_seq;
  template <class M, class F>
  static constexpr void fields(M& m, F&& f) {
    f("gid", m.gid);
    f("node_entities_info_seq", m.node_entities_info_seq);
  }
  friend constexpr bool operator==(const ParticipantEntitiesInfo&, const ParticipantEntitiesInfo&) = default;
};

/// The DDS topic ROS 2's graph is published on.
inline constexpr std::string_view kDiscoveryTopic = "ros_discovery_info";

}  // namespace dca::ros2
