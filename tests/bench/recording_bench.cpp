// The cost of recording a run: the scripted door opening at 1 kHz for 10 simulated seconds,
// recorded every 10 ms (dca sim's default --record-period) to MCAP and to CSV, beside the same run without
// recording, measured in the same run and alternated (A B C A B C); MCAP with chunks uncompressed, zstd (the
// default) and lz4 (--record-compression). RESULT lines on stdout (BENCHMARKS.md):
// per-step latencies in microseconds (the recording included), rtf = simulated / wall time of the steps,
// mb_per_sim_min = the file's size per simulated minute, record_us_p50 = the median cost of one record()
// call (all the run's signals: 7 MCAP messages or one CSV row).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

#include "worlds/door/door_script.h"
#include "worlds/door/recording.h"
#include "worlds/door/world.h"
#include "tests/bench/bench_util.h"

namespace {

using Clock = std::chrono::steady_clock;

constexpr int kSteps = 10000;      // 10 simulated seconds at 1 kHz
constexpr int kRecordEvery = 10;   // every 10 ms

// One run: the scripted opening, recorded to `path` ("" = not recorded). Prints its RESULT line.
void run(const std::string& variant, const std::string& path,
         dca::mcap::Compression how = dca::mcap::Compression::none) {
  dca::sim::World w(dca::sim::door_world());
  dca::sim::ScriptedDoorOpening script;
  std::optional<dca::sim::DoorRecording> rec;
  if (!path.empty()) {
    rec.emplace(path);
    dca::sim::RecordOptions o;
    o.compression = how;
    rec->recorder().configure(o);
  }
  std::vector<double> us;
  us.reserve(kSteps);
  std::vector<double> record_us;
  for (int i = 0; i < kSteps; ++i) {
    const dca::sim::Commands c = script.update(w);
    const auto t0 = Clock::now();
    w.set_commands(c);
    w.step();
    const auto t1 = Clock::now();
    if (rec && i % kRecordEvery == 0) rec->record(w.sensors(), static_cast<int>(script.phase()));
    const auto t2 = Clock::now();
    if (rec && i % kRecordEvery == 0) record_us.push_back(std::chrono::duration<double, std::micro>(t2 - t1).count());
    us.push_back(std::chrono::duration<double, std::micro>(t2 - t0).count());
  }
  double total = 0;
  for (double u : us) total += u;
  double mb_per_min = 0;
  if (rec) {
    std::string error;
    if (!rec->recorder().close(&error)) std::fprintf(stderr, "%s\n", error.c_str());
    struct stat st {};
    if (stat(path.c_str(), &st) == 0) mb_per_min = static_cast<double>(st.st_size) / 1e6 / (kSteps * 1e-3) * 60;
    std::fprintf(stderr, "%s\n", rec->recorder().summary().c_str());
    unlink(path.c_str());
  }
  std::sort(record_us.begin(), record_us.end());
  char extra[160];
  std::snprintf(extra, sizeof extra, " rtf=%.2f mb_per_sim_min=%.2f record_us_p50=%.2f", kSteps * 1e-3 * 1e6 / total,
                mb_per_min, dca::bench::quantile(record_us, 0.5));
  dca::bench::result("recording", variant, us, extra, 2);
}

}  // namespace

int main() {
  const std::string base = dca::bench::temp_path("dca_recording_bench");
  for (int round = 0; round < 2; ++round) {
    std::fprintf(stderr, "round %d\n", round + 1);
    run("door_1kHz_no_recording", "");
    run("door_1kHz_mcap_every_10ms", base + ".mcap");
    run("door_1kHz_mcap_zstd_every_10ms", base + ".mcap", dca::mcap::Compression::zstd);
    run("door_1kHz_mcap_lz4_every_10ms", base + ".mcap", dca::mcap::Compression::lz4);
    run("door_1kHz_csv_every_10ms", base + ".csv");
  }
  return 0;
}
