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
//
// calloc keeps that promise only for the first planes. glibc's malloc raises its mmap threshold
// to the size of every mapped block it frees, up to 32 MiB (mallopt(3), M_MMAP_THRESHOLD), and
// a plane is 5.4 MB at 1440x936 (21.6 MB for RGBA). Once one denoiser has been destroyed, or
// resized, the next planes come from the heap: calloc then clears reused memory itself, which
// writes every page, and free keeps the memory in the process. The evaluation, which makes new
// denoisers for each run of the light switch, peaked at 8.6 GB instead of 5.4 over three runs at
// 720x468 and ran out of the machine's 24 GB in its second run at 1440x936. So a plane of
// DirectMapBytes or more is mapped and unmapped here (POSIX mmap: anonymous pages read as zero
// until written), which malloc's tuning cannot change; smaller ones still come from calloc.
#ifndef hv_denoise_PlaneAllocator_h
#define hv_denoise_PlaneAllocator_h

#include "hv/DefaultInitAllocator.h"

#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <new>

#if defined(__unix__) || defined(__APPLE__)
#include <sys/mman.h>
#define HV_PLANES_MAPPED 1
#endif

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

  // glibc's own initial mmap threshold: below it a mapping's page rounding and system calls
  // would cost more than a cleared heap block.
  static constexpr std::size_t DirectMapBytes = 128 * 1024;

  T* allocate(std::size_t n)
  {
    // alignof(T) <= alignof(max_align_t) for every plane's element (floats and glm::vec4); a
    // mapping is page-aligned.
    static_assert(alignof(T) <= alignof(std::max_align_t), "calloc's alignment is too small");
    if (n > SIZE_MAX / sizeof(T))
    {
      throw std::bad_alloc();
    }
#ifdef HV_PLANES_MAPPED
    if (n * sizeof(T) >= DirectMapBytes)
    {
      // Each plane starts at its own cache line of the page (the next of 64, 17 lines on):
      // planes that all began on a page boundary would put a loop's pixel k of every plane at
      // the same address modulo 4 KiB, where a load from one plane can be held up by a store to
      // another (4K aliasing) and all of them fall in one set of the L1 cache. Heap blocks, which
      // the planes were before, fall at varied offsets of their pages. (Not measured apart: the
      // hour of the change was too noisy to time it; Documentation/Denoising.md.)
      static std::atomic<unsigned> planesMapped{ 0 };
      const std::size_t stagger = (planesMapped++ * 17u % 64u) * 64u;
      void* mapped = mmap(nullptr, n * sizeof(T) + stagger, PROT_READ | PROT_WRITE,
        MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
      if (mapped == MAP_FAILED)
      {
        throw std::bad_alloc();
      }
      return reinterpret_cast<T*>(static_cast<char*>(mapped) + stagger);
    }
#endif
    void* memory = std::calloc(n, sizeof(T));
    if (!memory && n > 0)
    {
      throw std::bad_alloc();
    }
    return static_cast<T*>(memory);
  }
  // n is the count allocate() was given (the allocator requirements), so the same test of its
  // size tells a mapping from a heap block.
  void deallocate(T* memory, std::size_t n) noexcept
  {
#ifdef HV_PLANES_MAPPED
    if (n * sizeof(T) >= DirectMapBytes)
    {
      // The mapping starts on a page boundary (4 KiB or a multiple of it) and the stagger is
      // below 4 KiB, so rounding the plane down to 4 KiB finds it.
      const std::uintptr_t address = reinterpret_cast<std::uintptr_t>(memory);
      const std::uintptr_t page = address & ~static_cast<std::uintptr_t>(4095);
      munmap(reinterpret_cast<void*>(page), n * sizeof(T) + (address - page));
      return;
    }
#endif
    std::free(memory);
  }
  // Stateless: hv::DefaultInitAllocator's == and != (every two compare equal) serve it too.
};
}
}

#endif
