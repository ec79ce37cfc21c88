#include "host/loop.h"

#include <gtest/gtest.h>

#include <boost/asio/post.hpp>
#include <csignal>

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
