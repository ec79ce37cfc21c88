#pragma once
// host/codec: pure encoders and decoders. No Asio, no Beast, no socket, nothing of host/net or host/web.
// The table of dca's ROS 2 message types (sdk/include/dca/msgs.h) by name, for the parts of dca that meet a
// message port's samples as bytes: the node checks them (host/port), taps and recordings show them as JSON with a
// JSON Schema per type (docs/recording.md), `dca types` lists them. A sample is the message's CDR
// (dca/msgs_cdr.h). See docs/data-plane.md, "Typed messages".
#include <cstddef>
#include <span>
#include <string>
#include <string_view>

#include <msgpack.hpp>

namespace dca::msgs {

/// One message type.
struct TypeInfo {
  std::string_view ros_name;   ///< "sensor_msgs/msg/JointState"
  std::string_view dds_name;   ///< "sensor_msgs::msg::dds_::JointState_"
  std::string_view type_hash;  ///< "RIHS01_..."
  std::size_t max_size;        ///< the most bytes of its CDR (cdr_max_size)
  /// True when `cdr` decodes as this type with at most 3 bytes after it (DDS's padding; no allocation). CDR does
  /// not name its type: another type's CDR of a length that fits passes, so types are checked at connect.
  bool (*valid)(std::span<const std::byte> cdr);
  /// The message's values as JSON, fields by name (dca/msgs_describe.h to_json); "null" when `cdr` does not
  /// decode.
  std::string (*json)(std::span<const std::byte> cdr);
  /// The JSON Schema of json()'s objects: numbers, integers, strings, arrays and objects by field name.
  std::string (*json_schema)();
  /// Its definition as an MCAP ros2msg schema holds it (dca/msgs_describe.h ros2msg_definition): what a `ros2`
  /// profile recording's channel of this type is described by.
  std::string (*ros2msg)();
  /// Packs the message as a msgpack map of its fields by name (nil when `cdr` does not decode).
  void (*pack)(std::span<const std::byte> cdr, msgpack::packer<msgpack::sbuffer>& pk);
  /// The CDR of the default message (zeros, the identity quaternion): what halt() writes to an actuator.
  std::span<const std::byte> (*zero)();
};

/// Every type, in dca::msgs::for_each_message_type's order.
std::span<const TypeInfo> types();
/// The type named `ros_name`, or nullptr.
const TypeInfo* find_type(std::string_view ros_name);

}  // namespace dca::msgs
