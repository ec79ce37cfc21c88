#pragma once
// host/rt: the real-time side of a node; no Asio, no Lua, nothing that allocates or locks after start-up.
//
// RtHistogram: fixed buckets written by one thread (the real-time thread) and read by any other while it runs,
// lock-free: 1 µs buckets below 1 ms, 100 µs buckets to 100 ms, one overflow bucket, an exact max. Relaxed
// atomics: a reader sees every bucket's own count exactly, the totals possibly one record apart.
#include <atomic>
#include <cstdint>
#include <utility>
#include <vector>

namespace dca::rt {

/// Quantiles of an RtHistogram, in microseconds.
struct RtSummary {
  std::uint64_t n = 0;
  double p50_us = 0, p99_us = 0, p999_us = 0, max_us = 0;
};

class RtHistogram {
 public:
  /// One record (negative durations count as 0). The writer thread only.
  void record(std::int64_t ns) {
    if (ns < 0) ns = 0;
    auto& b = buckets_[index(ns)];
    b.store(b.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    count_.store(count_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    if (ns > max_.load(std::memory_order_relaxed)) max_.store(ns, std::memory_order_relaxed);
  }
  std::uint64_t count() const { return count_.load(std::memory_order_relaxed); }
  std::int64_t max() const { return max_.load(std::memory_order_relaxed); }
  /// The q-quantile (0..1) in ns: the upper edge of its bucket, never above max(); 0 when empty.
  std::int64_t quantile(double q) const;
  /// p50, p99, p99.9 and max.
  RtSummary summary() const;
  /// The buckets that hold records, in order: (upper edge in ns, count). Allocates: not on the writer thread.
  std::vector<std::pair<std::int64_t, std::uint64_t>> buckets() const;

 private:
  static constexpr int kFine = 1000;   // 1 µs buckets, [0, 1 ms)
  static constexpr int kCoarse = 999;  // 100 µs buckets, [1 ms, 100.9 ms)
  static constexpr int kBuckets = kFine + kCoarse + 1;
  static int index(std::int64_t ns) {
    if (ns < 1'000'000) return static_cast<int>(ns / 1000);
    const std::int64_t c = (ns - 1'000'000) / 100'000;
    return c < kCoarse ? kFine + static_cast<int>(c) : kBuckets - 1;
  }
  static std::int64_t upper(int i) {
    return i < kFine ? (i + 1) * 1000LL : 1'000'000LL + (i - kFine + 1) * 100'000LL;
  }
  std::atomic<std::uint32_t> buckets_[kBuckets] = {};
  std::atomic<std::uint64_t> count_{0};
  std::atomic<std::int64_t> max_{0};
};

}  // namespace dca::rt
