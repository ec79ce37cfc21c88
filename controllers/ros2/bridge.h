#pragma once
// The process type ros2_bridge (docs/ros2.md): its ports are ROS 2 topics, by a table given as its first
// parameter. Each row is `TOPIC TYPE DIRECTION [PROFILE]`, rows separated by ';':
//   "/joint_states sensor_msgs/msg/JointState pub; /cmd_vel geometry_msgs/msg/Twist sub sensor_data"
// `pub` publishes to ROS 2 what arrives at the input Pub<T><k>; `sub` writes what ROS 2 publishes to the output
// Sub<T><k>, where T is the type's name (JointState) and k counts the earlier rows of the same type and direction
// (0, 1, ...; kSlots of each). PROFILE is a QoS profile of dds.h's qos_profile (default: "default"; /tf_static:
// "tf_static").
//
// Threads: DDS samples arrive on a thread of the bridge's own (a Cyclone waitset), are decoded there and handed to
// the node's loop through one bounded single-producer queue per `sub` row (when full the newest is dropped and
// counted); MainCalc, every `period` on the node's loop, moves them to the outputs and publishes the inputs' new
// samples. Nothing on the node's loop waits for DDS.
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include <dca/controller.h>

#include "dds.h"

namespace dca::ros2 {

/// The rows of each type and direction a bridge can have.
inline constexpr int kSlots = 2;

/// One row of the table.
struct Row {
  std::string topic;    ///< the ROS 2 topic, "/joint_states"
  std::string type;     ///< the ROS 2 type, "sensor_msgs/msg/JointState"
  bool pub = true;      ///< pub (dca -> ROS 2) or sub (ROS 2 -> dca)
  std::string profile;  ///< the QoS profile's name
  std::string port;     ///< the bridge's port: "PubJointState0", "SubTwist1"
};

/// The rows of `table`; throws std::invalid_argument naming the row and what is wrong.
std::vector<Row> parse_table(std::string_view table);

/// The message types a bridge's ports carry ("sensor_msgs/msg/JointState", ...), in the order of its ports.
std::vector<std::string> bridged_types();

class Link;  // one row's port and DDS endpoint (bridge.cpp)

/// The process type ros2_bridge.
class Ros2Bridge final : public PeriodicController {
  DCA_CONTROLLER(Ros2Bridge)

 public:
  ~Ros2Bridge() override;
  /// The participant (nullptr before the first configure()): for tests.
  const Participant* participant() const { return participant_.get(); }
  /// Samples from DDS dropped because a queue was full, or refused because they did not decode.
  std::uint64_t dropped() const;
  std::uint64_t refused() const;
  /// Row i's DDS writer or reader (before the first configure(): handle 0): for tests.
  Endpoint endpoint(std::size_t i) const;

 private:
  void on_configure() override;
  void on_start(const msgpack::object& init) override;
  void MainCalc() override;
  void open();
  void publish_graph();
  void receive_loop();

  std::vector<Row> rows_;
  std::string node_;
  ParticipantOptions options_;
  std::unique_ptr<Participant> participant_;
  std::vector<std::unique_ptr<Link>> links_;
  Endpoint graph_;
  std::unique_ptr<WaitSet> waitset_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
};

}  // namespace dca::ros2
