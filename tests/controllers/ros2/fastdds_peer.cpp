// Another vendor for the ros2 bridge's test (bridge_test.cpp): a Fast DDS 2.9 (Debian's libfastrtps-dev) program
// with ROS 2's topic and type names and ROS 2's default QoS (RELIABLE, VOLATILE, KEEP_LAST 10), its type support
// written by hand with Fast CDR (no fastddsgen in Debian). It subscribes to rt/joint_states
// (sensor_msgs/msg/JointState) and answers each sample on rt/cmd_vel (geometry_msgs/msg/Twist) with linear.x = the
// first position and angular.z = the second; it prints "ready" once its endpoints exist, "answers matched" when its
// writer first matches a reader, and "got <frame_id> <first name> <n>" to stdout for each sample.
//   ros2_fastdds_peer DOMAIN SECONDS [LOCAL PEER]
// UDP on the address LOCAL only (default 127.0.0.1), participant id 7, the initial peers at the address PEER
// (default 127.0.0.1): Cyclone's unicast discovery ports there. It ends after SECONDS, or when stdin closes.
#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastcdr/exceptions/Exception.h>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>

#include <poll.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace eprosima::fastdds::dds;  // NOLINT: a test program of Fast DDS's API
using eprosima::fastrtps::rtps::SerializedPayload_t;

struct Time {
  std::int32_t sec = 0;
  std::uint32_t nanosec = 0;
};
struct JointState {
  Time stamp;
  std::string frame_id;
  std::vector<std::string> name;
  std::vector<double> position, velocity, effort;
};
struct Twist {
  double linear[3] = {0, 0, 0};
  double angular[3] = {0, 0, 0};
};

void write_msg(eprosima::fastcdr::Cdr& c, const JointState& m) {
  c << m.stamp.sec << m.stamp.nanosec << m.frame_id << m.name << m.position << m.velocity << m.effort;
}
void read_msg(eprosima::fastcdr::Cdr& c, JointState& m) {
  c >> m.stamp.sec >> m.stamp.nanosec >> m.frame_id >> m.name >> m.position >> m.velocity >> m.effort;
}
void write_msg(eprosima::fastcdr::Cdr& c, const Twist& m) {
  for (const double v : m.linear) c << v;
  for (const double v : m.angular) c << v;
}
void read_msg(eprosima::fastcdr::Cdr& c, Twist& m) {
  for (double& v : m.linear) c >> v;
  for (double& v : m.angular) c >> v;
}

// A type support of T under its ROS 2 DDS name: XCDR1 with Fast CDR, no key.
template <class T>
class RosType : public TopicDataType {
 public:
  RosType(const char* dds_name, std::uint32_t max_size) {
    setName(dds_name);
    m_typeSize = max_size;
    m_isGetKeyDefined = false;
  }
  bool serialize(void* data, SerializedPayload_t* payload) override {
    eprosima::fastcdr::FastBuffer buf(reinterpret_cast<char*>(payload->data), payload->max_size);
    eprosima::fastcdr::Cdr c(buf, eprosima::fastcdr::Cdr::DEFAULT_ENDIAN, eprosima::fastcdr::Cdr::DDS_CDR);
    payload->encapsulation = c.endianness() == eprosima::fastcdr::Cdr::BIG_ENDIANNESS ? CDR_BE : CDR_LE;
    try {
      c.serialize_encapsulation();
      write_msg(c, *static_cast<const T*>(data));
    } catch (const eprosima::fastcdr::exception::Exception&) {
      return false;
    }
    payload->length = static_cast<std::uint32_t>(c.getSerializedDataLength());
    return true;
  }
  bool deserialize(SerializedPayload_t* payload, void* data) override {
    eprosima::fastcdr::FastBuffer buf(reinterpret_cast<char*>(payload->data), payload->length);
    eprosima::fastcdr::Cdr c(buf, eprosima::fastcdr::Cdr::DEFAULT_ENDIAN, eprosima::fastcdr::Cdr::DDS_CDR);
    try {
      c.read_encapsulation();
      read_msg(c, *static_cast<T*>(data));
    } catch (const eprosima::fastcdr::exception::Exception&) {
      return false;
    }
    return true;
  }
  std::function<std::uint32_t()> getSerializedSizeProvider(void*) override {
    return [this] { return m_typeSize; };
  }
  void* createData() override { return new T(); }
  void deleteData(void* data) override { delete static_cast<T*>(data); }
  bool getKey(void*, eprosima::fastrtps::rtps::InstanceHandle_t*, bool) override { return false; }
};

DomainParticipant* make_participant(int domain, const std::string& local, const std::string& peer) {
  DomainParticipantQos pq;
  pq.name("ros2_fastdds_peer");
  pq.wire_protocol().participant_id = 7;
  pq.transport().use_builtin_transports = false;  // UDP on loopback only: no shared memory with Cyclone
  auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
  udp->interfaceWhiteList.emplace_back(local);  // announce this address's locators only, as the bridge's Cyclone
  pq.transport().user_transports.push_back(udp);
  for (int i = 0; i < 8; ++i) {  // Cyclone's participants' unicast discovery ports (index i)
    eprosima::fastrtps::rtps::Locator_t l;
    eprosima::fastrtps::rtps::IPLocator::setIPv4(l, peer);
    l.port = static_cast<std::uint32_t>(7400 + 250 * domain + 10 + 2 * i);
    pq.wire_protocol().builtin.initialPeersList.push_back(l);
  }
  return DomainParticipantFactory::get_instance()->create_participant(domain, pq);
}

// ROS 2's default QoS: RELIABLE, VOLATILE, KEEP_LAST 10.
template <class Qos>
Qos ros_default(Qos q) {
  q.reliability().kind = RELIABLE_RELIABILITY_QOS;
  q.durability().kind = VOLATILE_DURABILITY_QOS;
  q.history().kind = KEEP_LAST_HISTORY_QOS;
  q.history().depth = 10;
  return q;
}

bool stdin_closed() {
  pollfd p{0, POLLIN, 0};
  if (poll(&p, 1, 0) <= 0) return false;
  char c;
  return read(0, &c, 1) <= 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3 && argc != 5) return std::fprintf(stderr, "usage: ros2_fastdds_peer DOMAIN SECONDS [LOCAL PEER]\n"), 2;
  const int domain = std::atoi(argv[1]);
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(std::atoi(argv[2]));
  DomainParticipant* p = make_participant(domain, argc == 5 ? argv[3] : "127.0.0.1", argc == 5 ? argv[4] : "127.0.0.1");
  if (p == nullptr) return std::fprintf(stderr, "ros2_fastdds_peer: no participant\n"), 1;
  TypeSupport js_type(new RosType<JointState>("sensor_msgs::msg::dds_::JointState_", 8192));
  TypeSupport twist_type(new RosType<Twist>("geometry_msgs::msg::dds_::Twist_", 64));
  js_type.register_type(p);
  twist_type.register_type(p);
  Topic* js_topic = p->create_topic("rt/joint_states", js_type.get_type_name(), TOPIC_QOS_DEFAULT);
  Topic* twist_topic = p->create_topic("rt/cmd_vel", twist_type.get_type_name(), TOPIC_QOS_DEFAULT);
  Subscriber* sub = p->create_subscriber(SUBSCRIBER_QOS_DEFAULT);
  Publisher* pub = p->create_publisher(PUBLISHER_QOS_DEFAULT);
  DataReader* reader = sub->create_datareader(js_topic, ros_default(DATAREADER_QOS_DEFAULT));
  DataWriter* writer = pub->create_datawriter(twist_topic, ros_default(DATAWRITER_QOS_DEFAULT));
  if (reader == nullptr || writer == nullptr) return std::fprintf(stderr, "ros2_fastdds_peer: no endpoints\n"), 1;
  std::printf("ready\n");
  std::fflush(stdout);
  JointState js;
  SampleInfo info;
  bool answers_matched = false;
  while (std::chrono::steady_clock::now() < end && !stdin_closed()) {
    // Discovery is not symmetric: the bridge may see this writer before it knows the bridge's reader, and a
    // VOLATILE answer written before then is lost. A test that wants the answer waits for this line.
    PublicationMatchedStatus matched;
    if (!answers_matched && writer->get_publication_matched_status(matched) == ReturnCode_t::RETCODE_OK &&
        matched.current_count > 0) {
      answers_matched = true;
      std::printf("answers matched\n");
      std::fflush(stdout);
    }
    if (reader->wait_for_unread_message(eprosima::fastrtps::Duration_t(0, 50000000)) &&
        reader->take_next_sample(&js, &info) == ReturnCode_t::RETCODE_OK && info.valid_data) {
      std::printf("got %s %s %zu\n", js.frame_id.c_str(), js.name.empty() ? "-" : js.name[0].c_str(),
                  js.position.size());
      std::fflush(stdout);
      Twist t;
      t.linear[0] = js.position.size() > 0 ? js.position[0] : 0;
      t.angular[2] = js.position.size() > 1 ? js.position[1] : 0;
      writer->write(&t);
    }
  }
  p->delete_contained_entities();
  DomainParticipantFactory::get_instance()->delete_participant(p);
  return 0;
}
