#pragma once
// host/rt: the real-time side of a node; no Asio, no Lua, nothing that allocates or locks after start-up.
//
// The real-time contract, measured (docs/time.md, "Real time"): code on the real-time thread (a controller's
// MainCalc) must not allocate, lock or block. A thread marked with enter() counts, until leave():
//   - allocations: every operator new (and delete) it calls, counted by the hooks in
//     tests/support/rt_hooks.cpp, linked into test and benchmark executables only (never into dca);
//   - locks: every pthread_mutex_lock (std::mutex included), counted by the same hooks;
//   - page faults: getrusage(RUSAGE_THREAD), minor and major, read at enter() and at counts().
// Without the hooks linked, allocations and locks stay 0 and hooked() says so.
#include <cstdint>

namespace dca::rt::contract {

struct Counts {
  std::uint64_t allocations = 0, locks = 0, page_faults = 0;
};

/// Starts counting on the calling thread (from zero).
void enter();
/// Stops counting on the calling thread.
void leave();
/// What the calling thread did since enter().
Counts counts();
/// True when the calling thread counts (the hooks ask).
bool counting();
/// The hooks' side.
void note_allocation();
void note_lock();
/// Called on each allocation or lock counted: a debugger's breakpoint (`break dca::rt::contract::counted`)
/// shows where a controller broke the contract.
__attribute__((noinline)) void counted();
/// True when the hooks are linked into this executable (they say so at static initialisation).
bool hooked();
void set_hooked();

}  // namespace dca::rt::contract
