#pragma once
// host/rt: the real-time side of a node; no Asio, no Lua, nothing that allocates or locks after start-up.
//
// Start-up of real time (docs/time.md, "Real time"): what a `rt { priority 80; cpu 1; }` declaration asks
// for. For the process: mlockall(MCL_CURRENT | MCL_FUTURE) and a heap reserve (malloc told never to give
// memory back or to mmap, then a block touched and freed, so later allocations find pages already faulted in).
// For the real-time thread: SCHED_FIFO at the priority, pinned to the CPU, its stack pre-faulted.
// Without the privilege (no CAP_SYS_NICE / CAP_IPC_LOCK, RLIMIT_RTPRIO or RLIMIT_MEMLOCK too low) each step that
// fails gives one warning naming the process and host, and what it runs with instead: the default scheduler,
// memory not locked. Never a failure to start.
#include <cstddef>
#include <string>

namespace dca::rt {

struct RtConfig {
  int priority = 0;                          ///< SCHED_FIFO priority 1..99; 0: the default scheduler
  int cpu = -1;                              ///< the CPU to pin the real-time thread to; -1: any
  bool lock_memory = true;                   ///< mlockall and the heap reserve (with priority > 0)
  std::size_t stack_prefault = 256 * 1024;   ///< bytes of the real-time thread's stack touched at start
  std::size_t heap_reserve = 8 * 1024 * 1024;  ///< bytes of heap faulted in and kept
  std::string who;                           ///< "PATH on host H": the warnings name it
};

/// "" when `c` is valid, else why ("rt priority must be 1..99, got 120").
std::string check(const RtConfig& c);
/// The process's part (memory), on any thread, once: "" or what was refused.
std::string setup_process(const RtConfig& c);
/// The calling thread's part (scheduler, CPU, stack): "" or what was refused.
std::string setup_thread(const RtConfig& c);
/// The one warning line for what was refused: "real time: WHO: a; b", or "" when nothing was.
std::string warning(const RtConfig& c, const std::string& a, const std::string& b = "");

}  // namespace dca::rt
