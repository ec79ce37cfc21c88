#pragma once
// The taps and the recording of a world process (docs/recording.md), the same for every world: the door world
// (sim/world_node.h) and any DeviceWorld (sim/device_node.h) serve them through one WorldTaps.
//
// Requests (answered here; `handle` returns false for any other):
//   tap {path, port_type, size, units, queue}   a tap input "tap:PATH" on the world component (host/net/tap.h),
//                                               recorded on a channel of its own (tap::topic_of, JSON Schema
//                                               tap::json_schema) when recording MCAP; answers {input}
//   record_end {}                               the recording closed now, what was written at the last tick
//                                               counted in first; answers {summary} ({} when not recording)
//   note {t, line, path, state}                 a line of the run on /dca/events at simulated time t; a black
//                                               box's trigger when state is aborted or lost (a fault)
//   blackbox {why}                              a black box's trigger now, on demand; answers {t}
// Being on the clock, the world takes in exactly the samples written before each tick: record_taps() at the
// start of each step records them at their writers' ticks (the stamps).
#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include "host/codec/wire.h"
#include "host/lockstep.h"
#include "host/net/tap.h"
#include "sim/recorder.h"

namespace dca {
class Channel;
}

namespace dca::sim {

class WorldTaps {
 public:
  /// `recorder`: the world's recording, or nullptr. `clock`: the world's clock master.
  WorldTaps(Lockstep& clock, std::unique_ptr<Recorder> recorder) : clock_(clock), recorder_(std::move(recorder)) {}
  /// Closes the recording if record_end did not, printing "dca sim: recorded SUMMARY" (or the error).
  ~WorldTaps();
  WorldTaps(const WorldTaps&) = delete;
  WorldTaps& operator=(const WorldTaps&) = delete;

  /// The world component's taps (set when the node makes the component).
  void attach(tap::Taps* taps) { taps_ = taps; }
  /// The recording, or nullptr (none, or closed by record_end).
  Recorder* recorder() const { return recorder_.get(); }
  /// The tapped samples taken in, recorded at their writers' ticks, with the count of those dropped.
  void record_taps();
  /// tap, record_end, note (see the header): true when `m` was one of them (and is answered).
  bool handle(const std::shared_ptr<Channel>& ch, const wire::Message& m, double now_s);

 private:
  void add_tap(const std::shared_ptr<Channel>& ch, const wire::Message& m);
  void end(const std::shared_ptr<Channel>& ch, const wire::Message& m);

  Lockstep& clock_;
  std::unique_ptr<Recorder> recorder_;
  tap::Taps* taps_ = nullptr;
  std::map<const tap::Taps::Tap*, std::uint16_t> channels_;  // each tap's recording channel
  // Whether `t`'s samples are recorded as they are, CDR (a message port in a recording of profile ros2).
  bool cdr(const tap::Taps::Tap& t) const;
};

}  // namespace dca::sim
