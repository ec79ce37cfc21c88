// The cost of keeping every topic's history (host/web/sample_history.h) in the monitor's sample hub (BENCHMARKS.md
// format): SampleHub::publish of one port's sample with the history kept (the default: 500 buckets) against the
// same hub keeping none (keep_history(0)), in the same run, alternated in batches of 1,000 samples at 1 kHz of
// simulated time (t advancing 1 ms a sample, so the buckets fill and merge as in a long run: each batch continues
// the run), for a scalar port and a 6-vector (an arm's joints).
//   RESULT bench=sample_history variant=<history|none>_<1|6> n=<batches> p50_us=.. (per sample) ... p50_ns=..
// A 1 kHz loop of P ports costs P x p50_ns x 1,000 ns a second of the root's loop.
// Usage: bench_sample_history [BATCHES]   (default 2000: 2,000 s of a 1 kHz run)
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <vector>

#include "host/web/sample_hub.h"
#include "tests/bench/bench_util.h"

namespace {

constexpr int kSamples = 1000;

// One batch: kSamples samples of topic `id`, continuing from sample `*n`. --> us per sample
double batch(dca::SampleHub& hub, std::uint32_t id, std::size_t width, std::int64_t* n) {
  std::vector<double> v(width);
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < kSamples; ++i, ++*n) {
    for (std::size_t k = 0; k < width; ++k) v[k] = std::sin(static_cast<double>(*n + static_cast<std::int64_t>(k)) * 1e-3);
    hub.publish(id, *n * 1000000, v);
  }
  const auto t1 = std::chrono::steady_clock::now();
  return std::chrono::duration<double, std::micro>(t1 - t0).count() / kSamples;
}

}  // namespace

int main(int argc, char** argv) {
  const int batches = argc > 1 ? std::max(10, std::atoi(argv[1])) : 2000;
  for (std::size_t width : {std::size_t{1}, std::size_t{6}}) {
    dca::SampleHub kept, none;
    none.keep_history(0);
    std::vector<std::string> fields(width, "value");
    const auto a_id = kept.add_topic("/main/a/Out", fields), b_id = none.add_topic("/main/a/Out", fields);
    std::vector<double> a, b;
    std::int64_t na = 0, nb = 0;
    for (int i = 0; i < batches; ++i) {  // alternated: A B A B
      a.push_back(batch(kept, a_id, width, &na));
      b.push_back(batch(none, b_id, width, &nb));
    }
    const std::string w = std::to_string(width);
    dca::bench::result_ns("sample_history", "history_" + w, a);
    dca::bench::result_ns("sample_history", "none_" + w, b);
  }
  return 0;
}
