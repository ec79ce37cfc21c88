#include "host/rt/contract.h"

#include <sys/resource.h>

#include <atomic>

namespace dca::rt::contract {

namespace {

thread_local bool t_counting = false;
thread_local std::uint64_t t_allocations = 0, t_locks = 0, t_faults_at_enter = 0;
std::atomic<bool> g_hooked{false};

std::uint64_t thread_faults() {
  rusage ru{};
  getrusage(RUSAGE_THREAD, &ru);
  return static_cast<std::uint64_t>(ru.ru_minflt) + static_cast<std::uint64_t>(ru.ru_majflt);
}

}  // namespace

void enter() {
  t_allocations = 0;
  t_locks = 0;
  t_faults_at_enter = thread_faults();
  t_counting = true;
}

void leave() { t_counting = false; }

Counts counts() { return {t_allocations, t_locks, thread_faults() - t_faults_at_enter}; }

bool counting() { return t_counting; }

void counted() { asm volatile(""); }

void note_allocation() {
  if (!t_counting) return;
  ++t_allocations;
  counted();
}

void note_lock() {
  if (!t_counting) return;
  ++t_locks;
  counted();
}

bool hooked() { return g_hooked.load(); }

void set_hooked() { g_hooked.store(true); }

}  // namespace dca::rt::contract
