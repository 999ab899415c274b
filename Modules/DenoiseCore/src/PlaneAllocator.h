// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Internal to HoloVolumeDenoiseCore: the allocator of the denoiser's per-pixel planes, which
// lets EyeState::resize zero them on every thread.
//
// A denoiser holds 91 floats a pixel per eye (its history, surfaces and filter planes), 490 MB
// an eye at the headset's 1440x936, and the kernel maps that memory a page at a time as it is
// first written. std::vector's resize(n, 0) and assign(n, 0) write it on one thread, so the
// first frame (and the first after a change of size) took all its page faults there: 2.97-3.46 s
// for a 1440x936 stereo pair on the project's 2-core virtual machine, where later frames take
// 75-90 ms. A vector with this allocator (hv::DefaultInitAllocator) leaves trivially
// constructible elements unwritten on resize(n), and EyeState::resize writes the zeros on every
// thread: 1.75-2.26 s (Documentation/Denoising.md, "The first frame"). Transparent huge pages
// for the planes were tried there and not kept: they halved the first frame again but slowed
// every later frame.
#ifndef hv_denoise_PlaneAllocator_h
#define hv_denoise_PlaneAllocator_h

#include "hv/DefaultInitAllocator.h"

namespace hv
{
namespace denoise
{
template <typename T>
using PlaneAllocator = hv::DefaultInitAllocator<T>;
}
}

#endif
