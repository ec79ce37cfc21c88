// A node's real-time thread (host/node_rt.h) in an executable without the contract's hooks (no
// tests/support/rt_hooks.cpp, as in `dca` itself): allocations and locks are not counted there, but page faults
// are, from getrusage(RUSAGE_THREAD), hooks or none. A leaf whose MainCalc touches a fresh page of anonymous
// memory each tick faults it in on the thread: the count says so (a first touch of such a page always faults).
#include <gtest/gtest.h>
#include <sys/mman.h>

#include <atomic>
#include <chrono>

#include <dca/component.h>

#include "host/node_rt.h"

namespace {

// Touches page `ticks` of a reserved (never touched) region at each 1 ms tick, up to its 64 pages.
class Toucher final : public dca::Component {
 public:
  explicit Toucher(dca::TimerServer& ts) : timers_(ts) {
    void* p = mmap(nullptr, kPages * kPage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    region_ = p == MAP_FAILED ? nullptr : static_cast<char*>(p);
  }
  ~Toucher() override {
    if (region_) munmap(region_, kPages * kPage);
  }
  const std::string& name() const override { return name_; }
  dca::PortSet& ports() override { return ports_; }
  bool configure(std::string*) override { return true; }
  bool start(dca::Bytes, std::string*) override {
    timer_ = timers_.every(1'000'000, [this] { tick(); }, name_);
    return true;
  }
  void halt() override {
    if (timer_) timers_.cancel(timer_);
    timer_ = 0;
  }
  bool mapped() const { return region_ != nullptr; }
  std::atomic<int> ticks{0};

 private:
  static constexpr std::size_t kPages = 64, kPage = 4096;
  void tick() {
    const int n = ticks.load();
    if (static_cast<std::size_t>(n) < kPages) region_[static_cast<std::size_t>(n) * kPage] = 1;
    ticks.store(n + 1);
  }
  std::string name_ = "/toucher";
  dca::TimerServer& timers_;
  dca::PortSet ports_;
  char* region_ = nullptr;
  dca::TimerServer::Id timer_ = 0;
};

TEST(RtHostWithoutHooks, CountsPageFaultsButNoAllocationsOrLocks) {
  ASSERT_FALSE(dca::rt::contract::hooked());
  boost::asio::io_context io;
  dca::rt::RtConfig config;
  config.cpu = 0;
  config.lock_memory = false;
  dca::RtHost host(io, config);
  Toucher leaf(host.timers());
  ASSERT_TRUE(leaf.mapped());
  host.adopt(leaf, [](const dca::ComponentEvent&) {});
  host.start();
  std::string error = "no answer";
  host.request(leaf, dca::RtHost::Op::Start, "", "", [&](const std::string& e) { error = e; });
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  // (the start's answer comes through the loop, and may come after the first faults: all three are waited for)
  while ((host.contract().page_faults == 0 || error == "no answer" || leaf.ticks.load() == 0) &&
         std::chrono::steady_clock::now() < deadline)
    io.run_for(std::chrono::milliseconds(5));
  EXPECT_EQ(error, "");
  EXPECT_GT(leaf.ticks.load(), 0);
  const auto c = host.contract();
  EXPECT_GT(c.page_faults, 0u);  // counted without the hooks
  EXPECT_EQ(c.allocations, 0u);  // not counted without them
  EXPECT_EQ(c.locks, 0u);
  host.stop();
  auto mirror = host.forget(leaf);
}

}  // namespace
