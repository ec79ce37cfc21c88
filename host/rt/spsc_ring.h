#pragma once
// host/rt: the real-time side of a node; no Asio, no Lua, nothing that allocates or locks after start-up.
//
// SpscRing<T, N>: a single-producer single-consumer ring of N slots (N a power of two), lock-free and
// wait-free, fixed capacity, no allocation: the only way data crosses between a node's I/O thread and its
// real-time thread (docs/time.md, "Real time"). One thread calls push(), one other thread calls pop(); a full
// ring refuses the push (the producer counts it), it never blocks.
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <new>
#include <type_traits>

namespace dca::rt {

template <class T, std::size_t N>
class SpscRing {
  static_assert(N >= 2 && (N & (N - 1)) == 0, "SpscRing: N must be a power of two");
  static_assert(std::is_trivially_copyable_v<T>, "SpscRing: T must be trivially copyable (no allocation)");

 public:
  /// Producer: copies `v` in; false when the ring is full (nothing written).
  bool push(const T& v) {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_cache_ == N) {
      tail_cache_ = tail_.load(std::memory_order_acquire);
      if (head - tail_cache_ == N) return false;
    }
    slots_[head & (N - 1)] = v;
    head_.store(head + 1, std::memory_order_release);
    return true;
  }
  /// Consumer: moves the oldest element into `out`; false when the ring is empty.
  bool pop(T& out) {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_cache_) {
      head_cache_ = head_.load(std::memory_order_acquire);
      if (tail == head_cache_) return false;
    }
    out = slots_[tail & (N - 1)];
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }
  /// Elements queued (exact from either side's own point of view, approximate from a third thread).
  std::size_t size() const {
    return head_.load(std::memory_order_acquire) - tail_.load(std::memory_order_acquire);
  }
  static constexpr std::size_t capacity() { return N; }

 private:
  static constexpr std::size_t kLine = 64;
  alignas(kLine) std::atomic<std::size_t> head_{0};  // written by the producer
  std::size_t tail_cache_ = 0;                       // the producer's last view of tail_
  alignas(kLine) std::atomic<std::size_t> tail_{0};  // written by the consumer
  std::size_t head_cache_ = 0;                       // the consumer's last view of head_
  alignas(kLine) T slots_[N];
};

}  // namespace dca::rt
