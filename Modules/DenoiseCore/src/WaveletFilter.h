// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Internal to HoloVolumeDenoiseCore: D1's spatial filter, in a source file of its own so that
// it is compiled with its own vector width (see Modules/DenoiseCore/CMakeLists.txt).
#ifndef hv_denoise_WaveletFilter_h
#define hv_denoise_WaveletFilter_h

#include "DenoisePlanes.h"

#include "hv/denoise/DenoiseKernels.h"

#include <vector>

namespace hv
{
namespace denoise
{
namespace detail
{
// One level of the edge-aware a-trous wavelet filter for the pixels [begin, end) of row y:
// 3x3 B-spline taps at distance `step`, each weighted by the edge-stopping functions and by
// the variance-guided luminance term (SVGF Eq. 5), whose scale comes from the 3x3-blurred
// variance. Per chunk of the span, a loop per tap computes the guide's terms of the weights,
// then one loop takes each pixel's nine taps; every loop reads its planes at consecutive
// pixels, so the compiler turns it into vector code.
// `depthGuide` is the plane the depth edge-stopping compares (the frame's first scatter depth,
// or the history's mean of it); the guide's depth spread stays the frame's.
// Each call writes the row's pixels of `out` and `outVariance` from those of `in` and
// `inVariance` around them; the rows of a level may therefore run in any order and in parallel.
void filterWaveletRow(const SurfacePlanes& guide, const PlaneVector<float> (&in)[4],
  const PlaneVector<float>& inVariance, ColourPlanes& out, PlaneVector<float>& outVariance,
  int width, int height, int y, int begin, int end, int step, float luminanceSigma,
  const EdgeStopping edges, const float* depthGuide);
}
}
}

#endif
