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

// Subpixel positions stratified over frames. The n-th sample of a pixel, counted over all its
// frames (frame * samplesPerPixel + s), sits at frac(rotation + n * alpha) with alpha = (1/p,
// 1/p^2), p = 1.3247... the plastic number: the R2 sequence (Roberts 2018, "The unreasonable
// effectiveness of quasirandom sequences"), rotated per pixel by a random offset
// (Cranley-Patterson). For a fixed n the position is uniform over the pixel, since the rotation is,
// so every estimate stays unbiased. Any run of consecutive points is the first points shifted by
// a constant, so whichever frames a progressive sum or the denoiser's history holds, their
// positions cover the pixel evenly: where an edge crosses the pixel its coverage converges
// about like 1/N instead of 1/sqrt(N) (TestSampling's SubpixelSequence tests measure it). The
// rotation depends on the pixel, eye and seed but not the frame, and the arithmetic is 32-bit
// fixed point, in which n * alpha wraps modulo 1 exactly for every n.
struct SubpixelSequence
{
  std::uint32_t rotationX;
  std::uint32_t rotationY;
};

HV_FUNCTION SubpixelSequence makeSubpixelSequence(
  std::uint32_t pixelIndex, std::uint32_t eye, std::uint64_t seed)
{
  // A key of its own (no frame in it), hashed apart from makePixelRng's keys.
  const std::uint64_t key = mix64(mix64(seed ^ 0x2545f4914f6cdd1dULL) ^
    mix64((static_cast<std::uint64_t>(eye) << 32) | pixelIndex));
  SubpixelSequence sequence;
  sequence.rotationX = static_cast<std::uint32_t>(key);
  sequence.rotationY = static_cast<std::uint32_t>(key >> 32);
  return sequence;
}

// The sample's offset in [0, 1)^2 from the pixel's corner.
HV_FUNCTION glm::vec2 subpixelOffset(const SubpixelSequence& sequence, std::uint32_t sampleIndex)
{
  constexpr std::uint32_t alphaX = 3242174889u; // round(2^32 / p)
  constexpr std::uint32_t alphaY = 2447445414u; // round(2^32 / p^2)
  const std::uint32_t x = sequence.rotationX + sampleIndex * alphaX;
  const std::uint32_t y = sequence.rotationY + sampleIndex * alphaY;
  // The top 24 bits, as Pcg32::nextFloat: exactly representable, below 1.
  return glm::vec2(static_cast<float>(x >> 8), static_cast<float>(y >> 8)) * (1.0f / 16777216.0f);
}
}

#endif
