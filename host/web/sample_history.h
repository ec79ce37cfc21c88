#pragma once
// host/web: HTTP/WebSocket, the only users of Beast. Included only by host/web, its bindings and taps.
// A topic's samples from the start of a run, bounded and decimated (SampleHub keeps one per numeric topic), so a
// viewer that picks a topic late, or after the run's end, sees it from t = 0. Pure, no I/O.
//
//   SampleHistory h(500);                 // at most 500 buckets: at most 1,000 rows
//   h.add(t_ns, values);                  // O(values), amortised (a merge of every bucket when full: O(buckets))
//   h.rows()                              // [[t_s, v1, ...], ...] in time order
//
// Time is cut into buckets of one width from the first sample's time; the width starts at 1 us and doubles
// (adjacent buckets merged in pairs) whenever a sample falls past the last bucket. A bucket keeps, per value, its
// minimum and its maximum and which came first, its first and its last sample's time. Its rows: one (a bucket of one
// sample, or one whose extremes are equal), else two, at its first and its last time, each value's earlier extreme
// in the first and its later one in the second. So every extreme the run had is kept whatever its length (a spike of
// one sample survives any decimation), its time within one bucket's width, and drawing the rows gives the same
// envelope as drawing every sample. A sample has at most kMaxValues values kept (more are left out); NaN is skipped.
// Memory: buckets x values x 24 bytes at most.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace dca {

class SampleHistory {
 public:
  static constexpr std::size_t kMaxValues = 64;
  explicit SampleHistory(std::size_t max_buckets = 500) : max_(max_buckets < 2 ? 2 : max_buckets) {}

  /// One sample at `t_ns` (a time before the last one's goes into the last bucket).
  void add(std::int64_t t_ns, std::span<const double> values);
  /// The rows kept, each {t in seconds, v1, ...}, in time order. A row has as many values as its bucket's widest
  /// sample (a value absent from a sample of a port whose size changed is NaN).
  std::vector<std::vector<double>> rows() const;
  /// rows() as JSON: "[[t,v1,...],...]" (a NaN, a value absent, as null).
  std::string json_rows() const;
  /// How many rows rows() gives (<= 2 x max_buckets), and how many samples were added.
  std::size_t row_count() const;
  std::uint64_t samples() const { return samples_; }
  std::size_t buckets() const { return buckets_.size(); }
  std::int64_t width_ns() const { return width_; }

 private:
  struct Extreme {
    double min, max;
    bool min_first;  // the minimum came before the maximum (or with it)
  };
  struct Bucket {
    std::int64_t index;          // (t - t0) / width
    std::int64_t first, last;    // its first and last sample's time, ns
    std::uint32_t n = 0;         // samples in it
    std::vector<Extreme> values;
  };
  static void merge(Bucket& into, const Bucket& later);
  void halve();  // width doubled: buckets merged in pairs

  std::size_t max_;
  std::vector<Bucket> buckets_;
  std::int64_t t0_ = 0, width_ = 1000;  // ns
  std::uint64_t samples_ = 0;
};

}  // namespace dca
