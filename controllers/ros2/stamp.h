#pragma once
// A clock's time (dca::Nanos: simulated or wall) as a message's builtin_interfaces/msg/Time stamp.
#include <dca/controller.h>
#include <dca/msgs.h>

namespace dca::ros2 {

inline msgs::Time stamp_of(Nanos t) {
  return {.sec = static_cast<std::int32_t>(t / 1'000'000'000),
          .nanosec = static_cast<std::uint32_t>(t % 1'000'000'000)};
}

}  // namespace dca::ros2
