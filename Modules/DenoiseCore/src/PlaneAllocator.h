// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Internal to HoloVolumeDenoiseCore: the allocator of the denoiser's per-pixel planes, which
// lets EyeState::resize zero them on every thread.
//
// A denoiser holds 89 floats a pixel per eye (its history, surfaces and filter planes), 480 MB
// an eye at the headset's 1440x936, and the kernel maps that memory a page at a time as it is
// first written. std::vector's resize(n, 0) and assign(n, 0) write it on one thread, so the
// first frame (and the first after a change of size) took all its page faults there: 2.97-3.46 s
// for a 1440x936 stereo pair on the project's 2-core virtual machine, where later frames take
// 75-90 ms. A vector with this allocator leaves trivially constructible elements unwritten on
// resize(n), and EyeState::resize writes the zeros on every thread: 1.75-2.26 s
// (Documentation/Denoising.md, "The first frame"). Transparent huge pages for the planes were
// tried there and not kept: they halved the first frame again but slowed every later frame.
#ifndef hv_denoise_PlaneAllocator_h
#define hv_denoise_PlaneAllocator_h

#include <cstddef>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>

namespace hv
{
namespace denoise
{
// std::allocator, but for construction without a value: default- rather than
// value-initialisation, which leaves a float, a glm::vec4 or a HistoryInfo unwritten.
// Stateless, so vectors that use it swap in O(1) as before.
template <typename T>
struct PlaneAllocator
{
  using value_type = T;

  PlaneAllocator() noexcept = default;
  template <typename U>
  PlaneAllocator(const PlaneAllocator<U>&) noexcept
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
bool operator==(const PlaneAllocator<T>&, const PlaneAllocator<U>&) noexcept
{
  return true;
}
template <typename T, typename U>
bool operator!=(const PlaneAllocator<T>&, const PlaneAllocator<U>&) noexcept
{
  return false;
}
}
}

#endif
