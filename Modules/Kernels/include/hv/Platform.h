// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_Platform_h
#define hv_Platform_h

// Per-sample kernels are compiled by the host compiler and, when CUDA is found, by nvcc.
// Everything marked HV_HOST_DEVICE must stay free of virtual calls, exceptions, RTTI and
// STL containers so that both compilers accept it.
#if defined(__CUDACC__)
#define HV_HOST_DEVICE __host__ __device__
#define HV_INLINE __forceinline__
#else
#define HV_HOST_DEVICE
#define HV_INLINE inline
#endif

#define HV_FUNCTION HV_HOST_DEVICE HV_INLINE

// A hint that `address` will be read soon, so a cache miss can overlap other work.
#if defined(__CUDA_ARCH__)
#define HV_PREFETCH(address) ((void)(address))
#elif defined(__GNUC__) || defined(__clang__)
#define HV_PREFETCH(address) __builtin_prefetch(address)
#else
#define HV_PREFETCH(address) ((void)(address))
#endif

// GLM's own functions carry __host__ __device__ under nvcc.
#ifndef GLM_FORCE_CXX17
#define GLM_FORCE_CXX17
#endif
#include <glm/glm.hpp>

namespace hv
{
constexpr float Pi = 3.14159265358979323846f;
constexpr float TwoPi = 2.0f * Pi;
constexpr float InvPi = 1.0f / Pi;
constexpr float InvFourPi = 1.0f / (4.0f * Pi);
constexpr float Infinity = 3.402823466e+38f; // FLT_MAX, usable in device code
constexpr float RayEpsilon = 1e-4f;

HV_FUNCTION float luminance(const glm::vec3& rgb)
{
  // Rec. 709 / sRGB primaries, as used for the environment-map importance weights.
  return 0.2126f * rgb.x + 0.7152f * rgb.y + 0.0722f * rgb.z;
}

// x < lo ? lo : (x > hi ? hi : x) for lo <= hi, a NaN passing through, written as glm's max
// then min (glm::clamp): the nested choice kept GCC 12 from vectorising a loop that called it
// beside other code (the cross-view weights; "control flow in loop").
HV_FUNCTION float clampf(float x, float lo, float hi)
{
  return glm::clamp(x, lo, hi);
}
}

#endif
