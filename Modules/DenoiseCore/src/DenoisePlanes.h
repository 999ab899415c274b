// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Internal to HoloVolumeDenoiseCore: the planes the denoiser's per-pixel loops read and write,
// and the attributes that compile those loops for several vector widths. Shared by
// StereoDenoiser.cxx and WaveletFilter.cxx, which is built with options of its own.
#ifndef hv_denoise_DenoisePlanes_h
#define hv_denoise_DenoisePlanes_h

#include "PlaneAllocator.h"

#include <glm/glm.hpp>

#include <array>
#include <cstddef>
#include <vector>

// The per-pixel loops are compiled for AVX-512, AVX2 and baseline x86-64, and the loader
// picks the widest that the CPU runs (GCC's function multiversioning, an ifunc), so one build
// runs everywhere and uses what the machine has. On the project's machine the wavelet filter
// took 68.5 ms per 1440x936 stereo pair with SSE2, 33.3 with AVX2 and 28.0 with AVX-512, and
// the other stages, which vectorise little, gain about a tenth (holovolume-denoise-benchmark).
// The versions compute every pixel alike (built with -ffp-contract=off; no sum runs across
// pixels), so the evaluation's tables came out identical with the baseline build. The
// exception is the wavelet filter, built with FMAs (see CMakeLists.txt): its AVX2 and AVX-512
// versions agree, and its baseline version differs from them in the last bits. The mapper's
// render loop and LightingCore's pixel loops are cloned the same way.
// Clang and other targets get the baseline build.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define HV_WIDEST_VECTORS                                                                          \
  __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define HV_WIDEST_VECTORS
#endif
// For a lambda or helper called inside one of those loops: inlined, it is compiled into each
// clone. A helper left out of line and not cloned runs its baseline (SSE-encoded) version from
// the AVX-512 clone, and GCC 12 made that call without a vzeroupper: with bilinearTaps called
// so, D2 took 51 ms per 1440x936 stereo pair instead of 15.8 on the project's machine. The
// test Build.WideClonesCallNoBaselineCode (Utilities/Scripts/check-clone-calls.sh) fails on
// such a call.
#if defined(__GNUC__)
#define HV_ALWAYS_INLINE __attribute__((always_inline))
#else
#define HV_ALWAYS_INLINE
#endif

namespace hv
{
namespace denoise
{
namespace detail
{
// Calls pixel(x, offset, weight) for the pixels x in [0, count) of a row span that starts at
// column `begin`, for a stencil whose taps lie tapColumn[t] columns (at most `reach`) and
// tapOffset[t] pixels away with weights tapWeight[t]. The pixels whose taps all lie inside the
// image's columns come first, in one loop that GCC vectorises (pixel must be inlined, and a
// loop inside it one that GCC unrolls fully); then the few within `reach` of the left and right
// edges, where a tap outside the image gets weight 0 and the centre pixel's offset, which adds
// exactly +0 to a sum of finite non-negative terms.
template <int Taps, typename Pixel>
HV_ALWAYS_INLINE inline void forStencilOfSpan(int begin, int count, int width, int reach,
  const int (&tapColumn)[Taps], const std::ptrdiff_t (&tapOffset)[Taps],
  const float (&tapWeight)[Taps], Pixel& pixel)
{
  const int interiorBegin = glm::clamp(reach - begin, 0, count);
  const int interiorEnd = glm::clamp(width - reach - begin, interiorBegin, count);
#pragma GCC ivdep
  for (int x = interiorBegin; x < interiorEnd; ++x)
  {
    pixel(x, tapOffset, tapWeight);
  }
  const int edgeRanges[2][2] = { { 0, interiorBegin }, { interiorEnd, count } };
  for (const auto& range : edgeRanges)
  {
    for (int x = range[0]; x < range[1]; ++x)
    {
      std::ptrdiff_t offset[Taps];
      float weight[Taps];
      for (int t = 0; t < Taps; ++t)
      {
        const int column = begin + x + tapColumn[t];
        const bool inside = column >= 0 && column < width;
        offset[t] = inside ? tapOffset[t] : 0;
        weight[t] = inside ? tapWeight[t] : 0.0f;
      }
      pixel(x, offset, weight);
    }
  }
}

// A plane of per-pixel values; resize(n) leaves them unwritten (PlaneAllocator.h).
template <typename T>
using PlaneVector = std::vector<T, PlaneAllocator<T>>;

// Radiance (or any RGBA signal) as four planes, so that the wavelet filter's loops over a row
// of taps read contiguous floats and vectorise.
struct ColourPlanes
{
  PlaneVector<float> channel[4];

  glm::vec4 at(std::size_t i) const
  {
    return glm::vec4(
      this->channel[0][i], this->channel[1][i], this->channel[2][i], this->channel[3][i]);
  }
  void set(std::size_t i, const glm::vec4& v)
  {
    this->channel[0][i] = v.x;
    this->channel[1][i] = v.y;
    this->channel[2][i] = v.z;
    this->channel[3][i] = v.w;
  }
};

// A frame's surfaces (the fields of Surface), one plane per field: the wavelet filter's
// edge-stopping functions read them, and the next frame's lookups read them as the previous
// frame's. `valid` is 1 where a surface is seen (Surface::kind is not SurfaceNone) and 0
// elsewhere, including everywhere outside the spans, so a tap or lookup may land anywhere and
// simply weigh nothing. `point` is Surface::firstScatterPosition, the point on the pixel-centre
// ray that is reprojected. coverageSharpness is the sharpness of the wavelet filter's coverage
// term, set by the temporal blending, which knows how many frames a pixel averages.
// As planes rather than an array of Surface: the surfaces stage then fills them in loops that
// vectorise, and each is written once (with the structs, the stage wrote every surface twice,
// struct and planes, and took 12.2-12.6 ms per 1440x936 stereo pair of which 6.4 went to the
// loop that copied the structs into the planes).
struct SurfacePlanes
{
  PlaneVector<float> depth, depthSpread, gradientMagnitude, normal[3], albedo[3], valid;
  PlaneVector<float> depthJitter, normalJitter;
  PlaneVector<float> coverageSharpness;
  PlaneVector<float> point[3];
  // The volume's normalised scalar at the first scatter point (EyeFrame::firstScatterScalar),
  // 0 where the frame had none; hasScalar says whether it did.
  PlaneVector<float> scalar;
  bool hasScalar = false;
  // On the frame of a new transfer function, for each pixel the scalar (a 3x3 mean) of the
  // material its history was gathered on: carried over from the frames of the same run of
  // changes, so that a drag that moves the material a little each frame is measured against
  // where it started. Sized on first use; hasScalarAnchor only on such a frame.
  PlaneVector<float> scalarAnchor;
  bool hasScalarAnchor = false;

  // The planes of Surface's fields (all but coverageSharpness).
  std::array<PlaneVector<float>*, 16> fields()
  {
    return { &this->depth, &this->depthSpread, &this->gradientMagnitude, &this->normal[0],
      &this->normal[1], &this->normal[2], &this->albedo[0], &this->albedo[1], &this->albedo[2],
      &this->valid, &this->depthJitter, &this->normalJitter, &this->point[0], &this->point[1],
      &this->point[2], &this->scalar };
  }
  // Pixel `to` gets the surface of pixel `from`.
  void copySurface(std::size_t from, std::size_t to)
  {
    for (PlaneVector<float>* plane : this->fields())
    {
      (*plane)[to] = (*plane)[from];
    }
  }
};
}
}
}

#endif
