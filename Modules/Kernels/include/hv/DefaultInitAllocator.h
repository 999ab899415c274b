// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_DefaultInitAllocator_h
#define hv_DefaultInitAllocator_h

#include <cstddef>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>

namespace hv
{
// std::allocator, but for construction without a value: default- rather than
// value-initialisation, so that std::vector's resize(n) leaves floats, integers and other
// trivially constructible elements unwritten. For the large arrays that a parallel loop fills
// next: the kernel maps fresh memory a page at a time where it is first written, and on the
// project's virtual machine such a page fault costs about 10 us (holovolume-denoise-benchmark
// took 1.38 M page faults and 13.4-13.8 s of system time, with 2 timed frames as with 8), so the
// first write should be the parallel loop's, not a zeroing pass on one thread. Stateless, so
// vectors that use it swap in O(1) as with std::allocator.
template <typename T>
struct DefaultInitAllocator
{
  using value_type = T;

  DefaultInitAllocator() noexcept = default;
  template <typename U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept
  {
  }

  T* allocate(std::size_t n) { return std::allocator<T>().allocate(n); }
  void deallocate(T* memory, std::size_t n) noexcept { std::allocator<T>().deallocate(memory, n); }

  template <typename U>
  void construct(U* element) noexcept(std::is_nothrow_default_constructible<U>::value)
  {
    ::new (static_cast<void*>(element)) U;
  }
  template <typename U, typename... Arguments>
  void construct(U* element, Arguments&&... arguments)
  {
    ::new (static_cast<void*>(element)) U(std::forward<Arguments>(arguments)...);
  }
};

template <typename T, typename U>
bool operator==(const DefaultInitAllocator<T>&, const DefaultInitAllocator<U>&) noexcept
{
  return true;
}
template <typename T, typename U>
bool operator!=(const DefaultInitAllocator<T>&, const DefaultInitAllocator<U>&) noexcept
{
  return false;
}
}

#endif
