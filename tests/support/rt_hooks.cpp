// The real-time contract's hooks (host/rt/contract.h): operator new/delete and pthread_mutex_lock, counted on a
// thread that called contract::enter(). Linked into test and benchmark executables only: the executable's
// definitions take the place of the C++ library's and interpose glibc's pthread_mutex_lock.
#include <dlfcn.h>
#include <pthread.h>

#include <cstdlib>
#include <new>

#include "host/rt/contract.h"

namespace {

const bool g_said = [] {
  dca::rt::contract::set_hooked();
  return true;
}();

void* counted(std::size_t n) {
  dca::rt::contract::note_allocation();
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}

void* counted_aligned(std::size_t n, std::align_val_t a) {
  dca::rt::contract::note_allocation();
  const auto al = static_cast<std::size_t>(a);
  const std::size_t rounded = n == 0 ? al : (n + al - 1) / al * al;  // aligned_alloc wants a multiple
  if (void* p = std::aligned_alloc(al, rounded)) return p;
  throw std::bad_alloc();
}

}  // namespace

using MutexLock = int (*)(pthread_mutex_t*);

// glibc's pthread_mutex_lock, found once (dlsym takes no pthread mutex: glibc locks with its own primitives).
MutexLock real_mutex_lock() {
  static const auto real = reinterpret_cast<MutexLock>(dlsym(RTLD_NEXT, "pthread_mutex_lock"));
  return real;
}

const MutexLock g_found_early = real_mutex_lock();  // at static initialisation, one thread

extern "C" int pthread_mutex_lock(pthread_mutex_t* m) {
  dca::rt::contract::note_lock();
  return real_mutex_lock()(m);
}

void* operator new(std::size_t n) { return counted(n); }
void* operator new[](std::size_t n) { return counted(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  dca::rt::contract::note_allocation();
  return std::malloc(n ? n : 1);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  dca::rt::contract::note_allocation();
  return std::malloc(n ? n : 1);
}
void* operator new(std::size_t n, std::align_val_t a) { return counted_aligned(n, a); }
void* operator new[](std::size_t n, std::align_val_t a) { return counted_aligned(n, a); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
