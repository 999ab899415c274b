// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_Random_h
#define hv_Random_h

#include "hv/Platform.h"

#include <cstdint>

namespace hv
{
// PCG32 (O'Neill 2014, "PCG: A family of simple fast space-efficient statistically good
// algorithms for random number generation"), the XSH-RR variant. Small state, so each pixel
// owns one and images do not depend on how pixels are distributed over threads.
struct Pcg32
{
  std::uint64_t state;
  std::uint64_t increment;

  HV_FUNCTION std::uint32_t nextUInt()
  {
    const std::uint64_t old = this->state;
    this->state = old * 6364136223846793005ULL + this->increment;
    const std::uint32_t xorShifted = static_cast<std::uint32_t>(((old >> 18u) ^ old) >> 27u);
    const std::uint32_t rotation = static_cast<std::uint32_t>(old >> 59u);
    return (xorShifted >> rotation) | (xorShifted << ((~rotation + 1u) & 31u));
  }

  // Uniform in [0, 1): the top 24 bits make every value exactly representable in float.
  HV_FUNCTION float nextFloat()
  {
    return static_cast<float>(this->nextUInt() >> 8) * (1.0f / 16777216.0f);
  }
};

// SplitMix64 finaliser: decorrelates nearby (pixel, frame, eye, seed) tuples.
HV_FUNCTION std::uint64_t mix64(std::uint64_t z)
{
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// The random stream of one pixel in one frame of one eye. Independent of thread count.
HV_FUNCTION Pcg32 makePixelRng(
  std::uint32_t pixelIndex, std::uint32_t frameIndex, std::uint32_t eye, std::uint64_t seed)
{
  Pcg32 rng;
  // Pixel and frame fill one 64-bit word; the eye is hashed on its own so no eye index can
  // alias another frame or pixel.
  const std::uint64_t key =
    mix64(seed ^ mix64((static_cast<std::uint64_t>(frameIndex) << 32) | pixelIndex) ^
      mix64(0x5851f42d4c957f2dULL + eye));
  rng.increment = (mix64(key + 0x9e3779b97f4a7c15ULL) << 1u) | 1u;
  rng.state = 0u;
  rng.nextUInt();
  rng.state += key;
  rng.nextUInt();
  return rng;
}
}

#endif
