#pragma once
// What the package ros2 needs of Eclipse Cyclone DDS (docs/ros2.md): a participant in a domain (its network
// interface and unicast peers as options), writers and readers of raw CDR samples on any topic and type (one
// sertype of opaque bytes: the bridge encodes and decodes with dca/msgs_cdr.h, so one bridge serves every message
// type), ROS 2's QoS profiles, ROS 2's topic names, the type hash in USER_DATA, and the GIDs that
// ros_discovery_info lists. Nothing here knows dca's ports.
//
//   Participant p({.domain = 7, .interface = "lo"});
//   Endpoint w = p.writer("/joint_states", JointState::dds_name, JointState::type_hash, qos_profile("default"));
//   write(w, cdr_bytes);                      // false when Cyclone refuses it
//   take(r, [](std::span<const std::byte> cdr) { ... });   // every sample waiting, in order
//
// Errors throw std::runtime_error naming the topic and Cyclone's reason.
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace dca::ros2 {

/// A DDS entity's handle (dds_entity_t).
using Entity = std::int32_t;

/// A GID as ROS 2 (Iron and later) has it: the entity's 16-byte DDS GUID.
using Gid = std::array<std::uint8_t, 16>;

/// A QoS profile of ROS 2's (rmw/qos_profiles.h).
struct QosProfile {
  bool reliable = true;          ///< RELIABLE, or BEST_EFFORT
  bool transient_local = false;  ///< TRANSIENT_LOCAL, or VOLATILE
  std::int32_t depth = 10;       ///< KEEP_LAST depth
};

/// The profile named `name`: "default" (RELIABLE, VOLATILE, KEEP_LAST 10), "sensor_data" (BEST_EFFORT, VOLATILE,
/// KEEP_LAST 5), "tf_static" (RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1; rclcpp's static broadcaster uses 1),
/// "transient_local" (RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 10); nothing for another name.
std::optional<QosProfile> qos_profile(std::string_view name);

/// The DDS topic of a ROS 2 topic: "/x/y" -> "rt/x/y". "" (and the reason in *why) when `ros` is not a fully
/// qualified ROS 2 topic name: '/' first, then tokens of letters, digits and '_' separated by single '/', no
/// token starting with a digit, no '/' last.
std::string dds_topic(std::string_view ros, std::string* why);

/// A writer or a reader and what the graph needs of it.
struct Endpoint {
  Entity handle = 0;
  Entity topic = 0;
  Gid gid{};
  const void* sertype = nullptr;  ///< the topic's raw sertype (Cyclone's ddsi_sertype)
};

/// How a participant reaches its peers.
struct ParticipantOptions {
  std::uint32_t domain = 0;    ///< the DDS domain id (ROS_DOMAIN_ID)
  std::string interface = {};  ///< a network interface's name or address ("" lets Cyclone choose)
  std::string peers = {};      ///< unicast peers' addresses, spaces between ("" : multicast discovery only)
  std::string enclave = "/";   ///< the participant's USER_DATA "enclave=...;" (ROS 2's security enclave)
  /// An SROS2 enclave's directory (identity_ca.cert.pem, cert.pem, key.pem, permissions_ca.cert.pem,
  /// governance.p7s, permissions.p7s): DDS Security through Cyclone's plugins; "" for none.
  std::string security = {};
};

/// The enclave an SROS2 enclave directory stands for: "/a/b" of ".../enclaves/a/b", "/" of any other.
std::string enclave_of(std::string_view dir);

/// One DDS participant: its domain (created with the options' configuration, shared by every participant of the
/// same domain id in this process, which must give the same options), writers and readers of raw CDR.
class Participant {
 public:
  explicit Participant(const ParticipantOptions& options);
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  Entity handle() const { return participant_; }
  Gid gid() const;
  /// A writer of `type` (its DDS name, "pkg::msg::dds_::T_") on `topic` (a DDS topic name), XCDR1, with
  /// USER_DATA "typehash=<hash>;" when `type_hash` is not empty.
  Endpoint writer(const std::string& topic, std::string_view type, std::string_view type_hash, QosProfile qos);
  /// A reader, likewise.
  Endpoint reader(const std::string& topic, std::string_view type, std::string_view type_hash, QosProfile qos);

 private:
  Endpoint endpoint(bool writer, const std::string& topic, std::string_view type, std::string_view type_hash,
                    QosProfile qos);
  std::uint32_t domain_;
  Entity participant_ = 0;
};

/// Writes one sample (`cdr`: its encapsulation header and body). False when Cyclone refuses it.
bool write(const Endpoint& writer, std::span<const std::byte> cdr);
/// Takes every sample waiting at `reader`, in order, calling `f` with each one's bytes (valid during the call).
/// The number taken.
std::size_t take(const Endpoint& reader, const std::function<void(std::span<const std::byte>)>& f);
/// The GID of any entity.
Gid gid_of(Entity e);

/// Waits on a set of readers from a thread of its own: wait() returns when one has data or wake() was called.
class WaitSet {
 public:
  explicit WaitSet(const Participant& p);
  ~WaitSet();
  WaitSet(const WaitSet&) = delete;
  WaitSet& operator=(const WaitSet&) = delete;
  /// Adds a reader (before the thread waits).
  void add(const Endpoint& reader);
  /// Blocks until a reader has data or wake() is called (or `timeout_ms` passed).
  void wait(std::int64_t timeout_ms);
  /// Makes wait() return (from another thread).
  void wake();

 private:
  Entity waitset_ = 0;
  Entity guard_ = 0;
  std::vector<Entity> conditions_;
};

}  // namespace dca::ros2
