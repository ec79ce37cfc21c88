#include "host/rt/setup.h"

#include <malloc.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <thread>

namespace dca::rt {

namespace {

std::string who(const RtConfig& c) { return c.who.empty() ? std::string("this process") : c.who; }

// Touches `bytes` of the calling thread's stack, so its pages are faulted in (and locked, under mlockall).
__attribute__((noinline)) void prefault_stack(std::size_t bytes) {
  constexpr std::size_t kChunk = 16 * 1024;
  unsigned char chunk[kChunk];
  std::memset(chunk, 0, kChunk);
  asm volatile("" : : "r"(chunk) : "memory");  // the writes stay
  if (bytes > kChunk) prefault_stack(bytes - kChunk);
}

}  // namespace

std::string check(const RtConfig& c) {
  if (c.priority < 0 || c.priority > 99)
    return "rt priority must be 1..99 (0: the default scheduler), got " + std::to_string(c.priority);
  const int cpus = static_cast<int>(std::thread::hardware_concurrency());
  if (c.cpu < -1 || (cpus > 0 && c.cpu >= cpus))
    return "rt cpu must be 0.." + std::to_string(cpus - 1) + " on this host, got " + std::to_string(c.cpu);
  return "";
}

std::string setup_process(const RtConfig& c) {
  if (c.priority == 0 || !c.lock_memory) return "";
  std::string warning;
  if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0)
    warning = std::string("memory not locked (mlockall: ") + std::strerror(errno) +
              "; needs CAP_IPC_LOCK or a larger RLIMIT_MEMLOCK): page faults may delay its real-time thread";
  // the heap reserve: freed memory stays in the process (no trimming, no mmap'd chunks to unmap)
  mallopt(M_TRIM_THRESHOLD, -1);
  mallopt(M_MMAP_MAX, 0);
  if (c.heap_reserve > 0) {
    auto* p = static_cast<volatile unsigned char*>(std::malloc(c.heap_reserve));
    if (p) {
      for (std::size_t i = 0; i < c.heap_reserve; i += 4096) p[i] = 0;
      std::free(const_cast<unsigned char*>(p));
    }
  }
  return warning;
}

std::string setup_thread(const RtConfig& c) {
  std::string warning;
  if (c.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(c.cpu, &set);
    if (const int e = pthread_setaffinity_np(pthread_self(), sizeof set, &set); e != 0)
      warning = "not pinned to cpu " + std::to_string(c.cpu) + " (" + std::strerror(e) + ")";
  }
  if (c.priority > 0) {
    sched_param sp{};
    sp.sched_priority = c.priority;
    if (const int e = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp); e != 0)
      warning += std::string(warning.empty() ? "" : "; ") + "SCHED_FIFO " + std::to_string(c.priority) +
                 " refused (" + std::strerror(e) + "; needs CAP_SYS_NICE or RLIMIT_RTPRIO): runs under the "
                 "default scheduler";
  }
  prefault_stack(c.stack_prefault);
  return warning;
}

std::string warning(const RtConfig& c, const std::string& a, const std::string& b) {
  if (a.empty() && b.empty()) return "";
  return "real time: " + who(c) + ": " + a + (a.empty() || b.empty() ? "" : "; ") + b;
}

}  // namespace dca::rt
