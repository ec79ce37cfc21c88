#include "host/web/sample_history.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "host/codec/json.h"

namespace dca {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr std::int64_t kMaxWidth = std::int64_t{1} << 61;  // ns: ~73 years a bucket, never reached in practice

}  // namespace

void SampleHistory::add(std::int64_t t_ns, std::span<const double> values) {
  if (samples_++ == 0) t0_ = t_ns;
  // the bucket's index, in unsigned arithmetic: no time from a peer can overflow it
  const auto index_of = [this](std::int64_t t) {
    const std::uint64_t d = t > t0_ ? static_cast<std::uint64_t>(t) - static_cast<std::uint64_t>(t0_) : 0;
    return static_cast<std::int64_t>(std::min<std::uint64_t>(d / static_cast<std::uint64_t>(width_), max_));
  };
  std::int64_t index = index_of(t_ns);
  while (index >= static_cast<std::int64_t>(max_) && width_ < kMaxWidth) {
    halve();
    index = index_of(t_ns);
  }
  index = std::min(index, static_cast<std::int64_t>(max_) - 1);  // (the widest width: the last bucket takes the rest)
  if (!buckets_.empty()) index = std::max(index, buckets_.back().index);  // never before the last bucket
  if (buckets_.empty() || buckets_.back().index != index) buckets_.push_back(Bucket{index, t_ns, t_ns, 0, {}});
  Bucket& b = buckets_.back();
  b.first = std::min(b.first, t_ns);
  b.last = std::max(b.last, t_ns);
  b.n++;
  const std::size_t n = std::min(values.size(), kMaxValues);
  if (b.values.size() < n) b.values.resize(n, Extreme{kNaN, kNaN, true});
  for (std::size_t i = 0; i < n; ++i) {
    const double v = values[i];
    Extreme& e = b.values[i];
    if (std::isnan(v)) continue;
    if (std::isnan(e.min)) {
      e = Extreme{v, v, true};
    } else if (v < e.min) {
      e.min = v;
      e.min_first = false;  // the minimum now comes after the maximum
    } else if (v > e.max) {
      e.max = v;
      e.min_first = true;
    }
  }
}

void SampleHistory::merge(Bucket& into, const Bucket& later) {
  into.first = std::min(into.first, later.first);
  into.last = std::max(into.last, later.last);
  into.n += later.n;
  if (into.values.size() < later.values.size()) into.values.resize(later.values.size(), Extreme{kNaN, kNaN, true});
  for (std::size_t i = 0; i < later.values.size(); ++i) {
    Extreme& a = into.values[i];
    const Extreme& b = later.values[i];
    if (std::isnan(b.min)) continue;
    if (std::isnan(a.min)) {
      a = b;
      continue;
    }
    // each extreme from the earlier bucket on a tie; the order of min and max follows where each came from
    const bool min_later = b.min < a.min, max_later = b.max > a.max;
    if (min_later) a.min = b.min;
    if (max_later) a.max = b.max;
    if (min_later && max_later) a.min_first = b.min_first;
    else if (min_later) a.min_first = false;
    else if (max_later) a.min_first = true;
  }
}

void SampleHistory::halve() {
  std::vector<Bucket> out;
  out.reserve(buckets_.size() / 2 + 1);
  for (Bucket& b : buckets_) {
    b.index /= 2;
    if (!out.empty() && out.back().index == b.index) merge(out.back(), b);
    else out.push_back(std::move(b));
  }
  buckets_ = std::move(out);
  width_ *= 2;
}

std::size_t SampleHistory::row_count() const {
  std::size_t n = 0;
  for (const Bucket& b : buckets_) n += b.n > 1 ? 2 : 1;
  return n;
}

std::vector<std::vector<double>> SampleHistory::rows() const {
  std::vector<std::vector<double>> out;
  out.reserve(row_count());
  for (const Bucket& b : buckets_) {
    std::vector<double> a{static_cast<double>(b.first) / 1e9};
    for (const Extreme& e : b.values) a.push_back(e.min_first ? e.min : e.max);
    if (b.n > 1) {
      std::vector<double> z{static_cast<double>(b.last) / 1e9};
      for (const Extreme& e : b.values) z.push_back(e.min_first ? e.max : e.min);
      out.push_back(std::move(a));
      out.push_back(std::move(z));
    } else {
      out.push_back(std::move(a));
    }
  }
  return out;
}

std::string SampleHistory::json_rows() const {
  std::string out = "[";
  for (const auto& row : rows()) {
    if (out.size() > 1) out += ',';
    json::append_numbers(out, row);
  }
  return out + "]";
}

}  // namespace dca
