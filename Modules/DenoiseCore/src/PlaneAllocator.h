// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Internal to HoloVolumeDenoiseCore: the allocator of the denoiser's per-pixel planes, whose
// memory arrives zeroed and is written only where the volume is seen.
//
// A denoiser holds 95 floats a pixel per eye (its history, surfaces and filter planes), 512 MB
// an eye at the headset's 1440x936, and the kernel maps that memory a page at a time as it is
// first written. On the project's 2-core virtual machine a page fault is expensive, and the
// first frame spent most of its time in them: 2.97-3.46 s for a 1440x936 stereo pair with
// std::vector's assign(n, 0) on one thread, 1.75-2.26 s with the zeros written on every thread
// (Documentation/Denoising.md, "The first frame"). Yet the stages work only on the spans of rows
// that see the volume (a fifth of the pixels in the benchmark's views), and the rest of each
// plane only has to read as zero. So the planes come from calloc, which returns memory the
// kernel has just mapped, and hence zeroed, without writing it (and zeroes a reused block
// itself): a page then costs its fault only when a stage first writes it, and one that no span
// reaches costs nothing. resize(n) leaves the elements unwritten, as hv::DefaultInitAllocator
// does; EyeState::resize therefore allocates every plane afresh instead of zeroing it.
#ifndef hv_denoise_PlaneAllocator_h
#define hv_denoise_PlaneAllocator_h

#include "hv/DefaultInitAllocator.h"

#include <cstdlib>
#include <new>

namespace hv
{
namespace denoise
{
template <typename T>
struct PlaneAllocator : hv::DefaultInitAllocator<T>
{
  using value_type = T;
  template <typename U>
  struct rebind
  {
    using other = PlaneAllocator<U>;
  };

  PlaneAllocator() noexcept = default;
  template <typename U>
  PlaneAllocator(const PlaneAllocator<U>&) noexcept
  {
  }

  T* allocate(std::size_t n)
  {
    // calloc checks n * sizeof(T) for overflow; alignof(T) <= alignof(max_align_t) for every
    // plane's element (floats and glm::vec4).
    static_assert(alignof(T) <= alignof(std::max_align_t), "calloc's alignment is too small");
    void* memory = std::calloc(n, sizeof(T));
    if (!memory && n > 0)
    {
      throw std::bad_alloc();
    }
    return static_cast<T*>(memory);
  }
  void deallocate(T* memory, std::size_t) noexcept { std::free(memory); }
  // Stateless: hv::DefaultInitAllocator's == and != (every two compare equal) serve it too.
};
}
}

#endif
