#pragma once

//! \file allocation_probe.h
//! \brief Counts operator new calls made on the haptic thread (DESIGN.md: it never allocates).
//! Replaces the global allocation functions: include it in exactly one file of a test or
//! benchmark binary.

#include <atomic>
#include <cstdlib>
#include <new>

#include "client/haptics/haptic_loop.h"

// The replacement pair is malloc/free, which g++ mistakes for a mismatch at inlined sites.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

inline std::atomic<std::uint64_t> g_haptic_allocations{0};

void* operator new(std::size_t size) {
  if (touchmend::haptics::on_haptic_thread()) g_haptic_allocations.fetch_add(1);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
