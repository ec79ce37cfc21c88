// The cost of the single-writer check per command sample (docs/safety.md, "One writer at a time on each command
// input"; BENCHMARKS.md format): a world's command input (host/port.h, a vector[1] with the world's 16 slots and
// two connections feeding it) takes one sample a tick as the world does (Input::deliver_from, take_latest,
// tick), exclusive (Input::set_exclusive, a lease of 5 ticks: the check) against the same input open (no check:
// the baseline), in alternated batches of 1,000 ticks, in one run. A third variant adds, each tick, a sample of
// the second connection that the check refuses (counted, on_refused called).
//   RESULT bench=single_writer variant=<open|exclusive|exclusive_refused> n=<batches> p50_us=.. (per tick) ...
//   p50_ns=..
// Usage: bench_single_writer [BATCHES]   (default 2000)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "host/port.h"
#include "tests/bench/bench_util.h"

namespace {

// A connection feeding the input, named as its writer.
class Feeder final : public dca::InputFeeder {
 public:
  explicit Feeder(std::string w) : writer_(std::move(w)) {}
  void input_gone() override {}
  std::string writer() const override { return writer_; }

 private:
  std::string writer_;
};

constexpr int kTicks = 1000;

// An input as the world has it: a command of one value, 16 slots, fed by two connections.
struct Setup {
  explicit Setup(bool exclusive) : in(dca::vector_port("joint.elbow_joint.velocity_command", 1), 16) {
    in.add_feeder(&holder);
    in.add_feeder(&second);
    if (exclusive) in.set_exclusive(5);
    in.on_refused = [this](const std::string&, const std::string&) { ++refused; };
  }
  Feeder holder{"main.up.Cmd"}, second{"main.down.Cmd"};
  dca::Input in;
  std::uint64_t refused = 0;
  double sum = 0;  // what the world reads, kept so that nothing is optimised away
};

// One batch: kTicks ticks, each a sample of the holder (and one of the second writer when `two`); microseconds
// per tick.
double batch(Setup& s, bool two) {
  double v = 0.5;
  const auto bytes = [&v] { return dca::Bytes{reinterpret_cast<const std::byte*>(&v), sizeof v}; };
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < kTicks; ++i) {
    v += 0.001;
    s.in.deliver_from(&s.holder, bytes());
    if (two) s.in.deliver_from(&s.second, bytes());
    if (s.in.take_latest()) s.sum += s.in.vector()[0];
    s.in.tick();
  }
  const auto t1 = std::chrono::steady_clock::now();
  return std::chrono::duration<double, std::micro>(t1 - t0).count() / kTicks;
}

}  // namespace

int main(int argc, char** argv) {
  const int batches = argc > 1 ? std::max(10, std::atoi(argv[1])) : 2000;
  Setup open(false), exclusive(true), refusing(true);
  std::vector<double> a, b, c;
  for (int i = 0; i < batches; ++i) {  // alternated: A B C A B C
    a.push_back(batch(open, false));
    b.push_back(batch(exclusive, false));
    c.push_back(batch(refusing, true));
  }
  dca::bench::result_ns("single_writer", "open", a);
  dca::bench::result_ns("single_writer", "exclusive", b);
  dca::bench::result_ns("single_writer", "exclusive_refused", c);
  std::fprintf(stderr, "refused %llu samples (expected %llu); checksum %.3f\n",
               static_cast<unsigned long long>(refusing.refused),
               static_cast<unsigned long long>(batches) * kTicks, open.sum + exclusive.sum + refusing.sum);
  return 0;
}
