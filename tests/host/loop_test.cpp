#include "host/loop.h"

#include <gtest/gtest.h>

#include <boost/asio/post.hpp>
#include <csignal>
#include <vector>

namespace {

using namespace std::chrono_literals;

TEST(LoopTest, RunUntilReturnsWhenThePredicateHolds) {
  dca::Loop loop;
  int n = 0;
  boost::asio::steady_timer t(loop.io(), 1ms);
  t.async_wait([&](const boost::system::error_code&) { n = 1; });
  EXPECT_TRUE(loop.run_until([&] { return n == 1; }, 10s));
}

TEST(LoopTest, RunUntilGivesUpAtItsDeadline) {
  dca::Loop loop;
  boost::asio::steady_timer t(loop.io(), 10s);
  t.async_wait([](const boost::system::error_code&) {});
  const auto start = std::chrono::steady_clock::now();
  EXPECT_FALSE(loop.run_until([] { return false; }, 20ms));
  EXPECT_GE(std::chrono::steady_clock::now() - start, 20ms);
  t.cancel();
}

TEST(LoopTest, RunUntilReturnsWhenNoWorkIsLeft) {
  dca::Loop loop;
  EXPECT_FALSE(loop.run_until([] { return false; }, 10s)) << "no work: returns at once, not after 10 s";
}

TEST(LoopTest, StopEndsRun) {
  dca::Loop loop;
  boost::asio::steady_timer t(loop.io(), 10s);
  t.async_wait([](const boost::system::error_code&) {});
  boost::asio::post(loop.io(), [&] { loop.stop(); });
  loop.run();
  EXPECT_TRUE(loop.stopped());
}

// Spinning (lock-step between rounds): within a window run() polls instead of sleeping, handlers run as
// usual, and a stop ends it; after the window, or without allow_spin(), it sleeps as io_context::run does.
TEST(LoopTest, ASpinWindowPollsRunsHandlersAndEndsOnStop) {
  dca::Loop loop;
  loop.allow_spin();
  std::vector<int> order;
  boost::asio::steady_timer later(loop.io(), 20ms), end(loop.io(), 40ms);
  boost::asio::post(loop.io(), [&] {
    order.push_back(1);
    loop.spin_for(10ms);  // then polls until 10 ms from now
  });
  later.async_wait([&](const boost::system::error_code&) { order.push_back(2); });  // after the window: slept for
  end.async_wait([&](const boost::system::error_code&) {
    order.push_back(3);
    loop.spin_for(1s);  // a window the stop ends
    boost::asio::post(loop.io(), [&] { loop.stop(); });
  });
  loop.run();
  EXPECT_EQ(order, (std::vector<int>{1, 2, 3}));
  EXPECT_GT(loop.spun(), 0u);
}

TEST(LoopTest, WithoutAllowSpinASpinWindowIsIgnored) {
  dca::Loop loop;
  boost::asio::post(loop.io(), [&] { loop.spin_for(1s); });
  boost::asio::steady_timer t(loop.io(), 5ms);
  t.async_wait([](const boost::system::error_code&) {});
  loop.run();  // out of work after the timer: returns
  EXPECT_EQ(loop.spun(), 0u);
}

TEST(LoopTest, SignalsAreDeliveredFromTheLoop) {
  dca::Loop loop;
  int got = 0;
  loop.on_signals({SIGUSR1}, [&](int s) {
    got = s;
    loop.stop();
  });
  std::raise(SIGUSR1);
  loop.run();
  EXPECT_EQ(got, SIGUSR1);
}

}  // namespace
