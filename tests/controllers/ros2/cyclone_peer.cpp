// A second DDS participant in a process of its own for the ros2 bridge's test (bridge_test.cpp): Cyclone DDS
// through the package's dds.h, secured by an SROS2 enclave or not. It subscribes to rt/joint_states
// (sensor_msgs/msg/JointState, ROS 2's default QoS) and answers each sample on rt/cmd_vel
// (geometry_msgs/msg/Twist) with linear.x = the first position; it prints
//   "ready"                         once its endpoints exist
//   "saw participant"               when it first discovers another participant (DCPSParticipant)
//   "answers matched"               when its writer first matches a reader (an answer written before is lost)
//   "got <frame_id> <n positions>"  for each JointState
//   "end got=<n>"                   when it ends: after SECONDS, or when stdin closes
//   ros2_cyclone_peer DOMAIN SECONDS ENCLAVE_DIR|-    (on loopback: interface lo, peer 127.0.0.1)
#include <dds/dds.h>

#include <poll.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <string>
#include <thread>

#include <dca/msgs.h>
#include <dca/msgs_cdr.h>

#include "dds.h"

namespace {

bool stdin_closed() {
  pollfd p{0, POLLIN, 0};
  if (poll(&p, 1, 0) <= 0) return false;
  char c;
  return read(0, &c, 1) <= 0;
}

// True once a participant other than `self` has been discovered.
bool saw_another(dds_entity_t builtin, const dca::ros2::Gid& self) {
  void* samples[4] = {};
  dds_sample_info_t infos[4];
  const dds_return_t n = dds_take(builtin, samples, infos, 4, 4);
  bool other = false;
  for (dds_return_t i = 0; i < n; ++i) {
    const auto* p = static_cast<const dds_builtintopic_participant_t*>(samples[i]);
    if (infos[i].valid_data && std::memcmp(p->key.v, self.data(), self.size()) != 0) other = true;
  }
  if (n > 0) dds_return_loan(builtin, samples, n);
  return other;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) return std::fprintf(stderr, "usage: ros2_cyclone_peer DOMAIN SECONDS ENCLAVE_DIR|-\n"), 2;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(std::atoi(argv[2]));
  dca::ros2::ParticipantOptions options{
      .domain = static_cast<std::uint32_t>(std::atoi(argv[1])), .interface = "lo", .peers = "127.0.0.1"};
  if (std::strcmp(argv[3], "-") != 0) options.security = argv[3];
  try {
    dca::ros2::Participant p(options);
    const auto qos = *dca::ros2::qos_profile("default");
    using dca::msgs::JointState;
    using dca::msgs::Twist;
    const auto reader = p.reader("rt/joint_states", JointState::dds_name, JointState::type_hash, qos);
    const auto writer = p.writer("rt/cmd_vel", Twist::dds_name, Twist::type_hash, qos);
    const dds_entity_t builtin = dds_create_reader(p.handle(), DDS_BUILTIN_TOPIC_DCPSPARTICIPANT, nullptr, nullptr);
    std::printf("ready\n");
    std::fflush(stdout);
    bool saw = false;
    bool answers_matched = false;
    int got = 0;
    auto js = std::make_unique<JointState>();
    while (std::chrono::steady_clock::now() < end && !stdin_closed()) {
      if (!saw && builtin > 0 && saw_another(builtin, p.gid())) {
        saw = true;
        std::printf("saw participant\n");
        std::fflush(stdout);
      }
      dds_publication_matched_status_t st;
      if (!answers_matched && dds_get_publication_matched_status(writer.handle, &st) == DDS_RETCODE_OK &&
          st.current_count > 0) {
        answers_matched = true;
        std::printf("answers matched\n");
        std::fflush(stdout);
      }
      dca::ros2::take(reader, [&](std::span<const std::byte> cdr) {
        if (!dca::msgs::cdr_decode(cdr, *js)) return;
        ++got;
        std::printf("got %s %zu\n", std::string(js->header.frame_id.view()).c_str(), js->position.size());
        std::fflush(stdout);
        Twist t;
        t.linear.x = js->position.empty() ? 0 : js->position[0];
        std::array<std::byte, dca::msgs::cdr_max_size<Twist>> buf;
        (void)dca::ros2::write(writer, std::span(buf).first(dca::msgs::cdr_encode(t, buf)));
      });
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    std::printf("end got=%d\n", got);
    std::fflush(stdout);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ros2_cyclone_peer: %s\n", e.what());
    return 1;
  }
  return 0;
}
