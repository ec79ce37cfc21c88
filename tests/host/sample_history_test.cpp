// A topic's history (host/web/sample_history.h) and the hub's (host/web/sample_hub.h): bounded however long the
// run, from its first sample to its last, every extreme kept (a spike of one sample in a million), min and max in
// their order, times from a peer that cannot overflow it, and a history per numeric topic of the hub.
#include "host/web/sample_history.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "host/web/sample_hub.h"

namespace {

using Rows = std::vector<std::vector<double>>;

double column_min(const Rows& rows, std::size_t k) {
  double m = INFINITY;
  for (const auto& r : rows) m = std::min(m, r.at(k));
  return m;
}
double column_max(const Rows& rows, std::size_t k) {
  double m = -INFINITY;
  for (const auto& r : rows) m = std::max(m, r.at(k));
  return m;
}

TEST(SampleHistory, BoundedFromTheFirstSampleToTheLast) {
  dca::SampleHistory h(100);
  const std::int64_t ms = 1000000;
  for (std::int64_t i = 0; i < 1000000; ++i) {  // 1,000 s at 1 kHz
    const double v[] = {std::sin(static_cast<double>(i) * 1e-3)};
    h.add(5 * ms + i * ms, v);
    ASSERT_LE(h.buckets(), 100u);
  }
  const Rows rows = h.rows();
  EXPECT_EQ(h.samples(), 1000000u);
  EXPECT_LE(rows.size(), 200u);
  EXPECT_GE(rows.size(), 100u);  // at least half the buckets in use: the width only doubles when full
  EXPECT_EQ(rows.size(), h.row_count());
  EXPECT_DOUBLE_EQ(rows.front()[0], 0.005);
  EXPECT_DOUBLE_EQ(rows.back()[0], 0.005 + 999.999);
  for (std::size_t i = 1; i < rows.size(); ++i) ASSERT_LE(rows[i - 1][0], rows[i][0]) << i;
  EXPECT_NEAR(column_min(rows, 1), -1, 1e-6);
  EXPECT_NEAR(column_max(rows, 1), 1, 1e-6);
}

TEST(SampleHistory, DecimationKeepsEveryExtreme) {
  dca::SampleHistory h(50);
  for (int i = 0; i < 200000; ++i) {
    double v[] = {0, 1};
    if (i == 123457) v[0] = 7;    // a spike of one sample
    if (i == 199998) v[1] = -3;   // and a dip near the end
    h.add(std::int64_t{i} * 100000, v);
  }
  const Rows rows = h.rows();
  EXPECT_LE(rows.size(), 100u);
  EXPECT_EQ(column_max(rows, 1), 7);
  EXPECT_EQ(column_min(rows, 1), 0);
  EXPECT_EQ(column_min(rows, 2), -3);
  EXPECT_EQ(column_max(rows, 2), 1);
  // the spike within one bucket's width of its time
  for (const auto& r : rows) {
    if (r[1] == 7) {
      EXPECT_NEAR(r[0], 12345.7e-3, static_cast<double>(h.width_ns()) / 1e9);
    }
  }
}

TEST(SampleHistory, MinAndMaxKeepTheirOrder) {
  dca::SampleHistory h(2);  // two buckets: the first half of the run, and the second
  const double up[] = {1}, top[] = {9}, down[] = {-4}, back[] = {0};
  h.add(0, up);
  h.add(10, top);   // the maximum first...
  h.add(20, down);  // ...then the minimum
  h.add(1000, back);
  h.add(1010, down);
  h.add(1020, top);  // here the minimum first
  const Rows rows = h.rows();
  ASSERT_EQ(rows.size(), 4u) << h.width_ns();
  EXPECT_EQ(rows[0][1], 9);
  EXPECT_EQ(rows[1][1], -4);
  EXPECT_EQ(rows[2][1], -4);
  EXPECT_EQ(rows[3][1], 9);
  EXPECT_DOUBLE_EQ(rows[0][0], 0);
  EXPECT_DOUBLE_EQ(rows[1][0], 20e-9);
  EXPECT_DOUBLE_EQ(rows[3][0], 1020e-9);
}

TEST(SampleHistory, AnyTimeFromAPeerIsTaken) {
  dca::SampleHistory h(10);
  const double v[] = {1}, w[] = {2};
  h.add(std::numeric_limits<std::int64_t>::min(), v);
  h.add(std::numeric_limits<std::int64_t>::max(), w);
  h.add(0, v);  // before the last one's: into the last bucket
  h.add(-5, w);
  EXPECT_LE(h.buckets(), 10u);
  // times all over the range, at the widest width: still at most its buckets
  dca::SampleHistory two(2);
  two.add(0, v);
  two.add(5000000000000000000, w);                       // the widest width's second bucket
  two.add(std::numeric_limits<std::int64_t>::max(), w);  // past it
  EXPECT_LE(two.buckets(), 2u);
  std::uint64_t x = 88172645463325252ull;
  for (int i = 0; i < 10000; ++i) {
    x ^= x << 13, x ^= x >> 7, x ^= x << 17;  // xorshift64
    two.add(static_cast<std::int64_t>(x), v);
    ASSERT_LE(two.buckets(), 2u) << i;
  }
  EXPECT_LE(two.row_count(), 4u);
  const Rows rows = h.rows();
  ASSERT_FALSE(rows.empty());
  EXPECT_EQ(column_max(rows, 1), 2);
  for (std::size_t i = 1; i < rows.size(); ++i) ASSERT_LE(rows[i - 1][0], rows[i][0]) << i;
}

TEST(SampleHistory, NaNsAndSizesThatChange) {
  dca::SampleHistory h(10);
  const double a[] = {NAN, 1}, b[] = {2}, c[] = {3, 4, 5};
  h.add(0, a);
  h.add(1000000000, b);
  h.add(2000000000, c);
  std::vector<double> wide(100, 1.0);
  h.add(3000000000, wide);
  const Rows rows = h.rows();
  ASSERT_EQ(rows.size(), 4u);
  EXPECT_TRUE(std::isnan(rows[0][1]));  // never a number in its bucket: null in JSON
  EXPECT_EQ(rows[0][2], 1);
  EXPECT_EQ(rows[1].size(), 2u);
  EXPECT_EQ(rows[2].size(), 4u);
  EXPECT_EQ(rows[3].size(), 1 + dca::SampleHistory::kMaxValues);  // past kMaxValues, values are left out
  EXPECT_EQ(h.json_rows().substr(0, 12), "[[0,null,1],");
}

TEST(SampleHub, KeepsEachNumericTopicsHistory) {
  dca::SampleHub hub;
  const auto a = hub.add_topic("/main/a/Out", {"value"});
  const auto f = hub.add_topic("/world/links/frames", {});
  hub.set_frames(f, {{"base", "l1"}});
  const auto ev = hub.add_stream_topic("/dca/events", "dca/events", "{}");
  const double v[] = {1}, fr[] = {0, 0, 0, 0, 0, 0, 1};
  EXPECT_EQ(hub.history(a), nullptr);  // no sample yet
  for (int i = 0; i < 3000; ++i) hub.publish(a, std::int64_t{i} * 1000000, v);
  hub.publish(f, 0, fr);
  hub.publish_message(ev, 0, "{}");
  ASSERT_NE(hub.history(a), nullptr);
  EXPECT_EQ(hub.history(a)->samples(), 3000u);
  EXPECT_LE(hub.history(a)->row_count(), 2 * hub.history_buckets());
  EXPECT_EQ(hub.history(f), nullptr);   // link frames: the 3D view's last sample, not a plot
  EXPECT_EQ(hub.history(ev), nullptr);  // a stream of messages
  hub.add_topic("/main/a/Out", {"value"});  // the same fields: the history goes on
  EXPECT_NE(hub.history(a), nullptr);
  hub.add_topic("/main/a/Out", {"value[0]", "value[1]"});  // others: it starts again
  EXPECT_EQ(hub.history(a), nullptr);
  hub.publish(a, 0, v);
  hub.remove_topic(a);
  EXPECT_EQ(hub.history(a), nullptr);
  hub.keep_history(0);
  const auto b = hub.add_topic("/main/b/Out", {"value"});
  hub.publish(b, 0, v);
  EXPECT_EQ(hub.history(b), nullptr);
}

}  // namespace
