// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "WaveletFilter.h"

#include <algorithm>
#include <cmath>

namespace hv
{
namespace denoise
{
namespace detail
{
HV_WIDEST_VECTORS void filterWaveletRow(const SurfacePlanes& guide,
  const PlaneVector<float> (&in)[4], const PlaneVector<float>& inVariance, ColourPlanes& out,
  PlaneVector<float>& outVariance, int width, int height, int y, int begin, int end, int step,
  float luminanceSigma, const EdgeStopping edges, const float* depthGuide)
{
  // The loops are marked ivdep: their planes never overlap (GCC honours __restrict on these
  // local pointers only in part), which is what lets it vectorise them.
  static const float kernel[3] = { 0.25f, 0.5f, 0.25f };
  const int count = end - begin;
  // The second loop below takes the span in chunks of this many pixels (see there).
  constexpr int chunk = 512;
  thread_local std::vector<float> scratch;
  // The variance blur's two planes of the span, and the eight taps' exponents of a chunk.
  scratch.resize(static_cast<std::size_t>(count) * 2 + 8 * chunk);
  float* __restrict blurWeight = scratch.data();
  float* __restrict blurredVariance = scratch.data() + count;
  const std::size_t row = static_cast<std::size_t>(y) * width + begin; // pixel of x = begin

  const float* __restrict valid = guide.valid.data();
  const float* __restrict variance = inVariance.data();
  // SVGF's g3x3: the variance blurred over the seen pixels of the 3x3 neighbourhood, each
  // pixel's nine taps in one pass with the sums in registers. They are added in the order of
  // the rows and then the columns, starting from 0; a tap outside the image has weight 0 and
  // reads the centre pixel, which adds exactly +0.
  {
    std::ptrdiff_t blurOffset[9];
    float blurKernel[9];
    int blurColumn[9];
    for (int dy = -1, t = 0; dy <= 1; ++dy)
    {
      const bool rowInside = y + dy >= 0 && y + dy < height;
      for (int dx = -1; dx <= 1; ++dx, ++t)
      {
        blurColumn[t] = dx;
        blurOffset[t] = rowInside ? static_cast<std::ptrdiff_t>(dy) * width + dx : 0;
        blurKernel[t] = rowInside ? kernel[dx + 1] * kernel[dy + 1] : 0.0f;
      }
    }
    auto blurPixel = [&](int x, const std::ptrdiff_t(&offset)[9], const float(&k)[9])
                       HV_ALWAYS_INLINE
    {
      const std::size_t i = row + x;
      float varianceSum = 0.0f, weightSum = 0.0f;
      for (int t = 0; t < 9; ++t)
      {
        const std::size_t j = i + offset[t];
        varianceSum += k[t] * valid[j] * variance[j];
        weightSum += k[t] * valid[j];
      }
      blurredVariance[x] = varianceSum;
      blurWeight[x] = weightSum;
    };
    forStencilOfSpan(begin, count, width, 1, blurColumn, blurOffset, blurKernel, blurPixel);
  }

  const float* __restrict r = in[0].data();
  const float* __restrict g = in[1].data();
  const float* __restrict b = in[2].data();
  const float* __restrict a = in[3].data();
  const float* __restrict depth = depthGuide;
  const float* __restrict spread = guide.depthSpread.data();
  const float* __restrict gradient = guide.gradientMagnitude.data();
  const float* __restrict nx = guide.normal[0].data();
  const float* __restrict ny = guide.normal[1].data();
  const float* __restrict nz = guide.normal[2].data();
  const float* __restrict ax = guide.albedo[0].data();
  const float* __restrict ay = guide.albedo[1].data();
  const float* __restrict az = guide.albedo[2].data();
  const float* __restrict coverageSharpness = guide.coverageSharpness.data();
  float* __restrict filteredRed = out.channel[0].data();
  float* __restrict filteredGreen = out.channel[1].data();
  float* __restrict filteredBlue = out.channel[2].data();
  float* __restrict filteredCoverage = out.channel[3].data();
  float* __restrict filteredVariance = outVariance.data();
  const float inverseAlbedo = inverseTwoSigmaSquared(edges.albedoSigma);

  // The eight taps around the centre, in the order the sums take them (row by row), with their
  // plane offsets and B-spline weights. A tap outside the image gets weight 0 and reads the
  // centre pixel instead: it adds exactly +0 to every sum, as if it were left out.
  std::ptrdiff_t tapOffset[8];
  float tapKernel[8];
  int tapColumn[8];
  int tap = 0;
  for (int dy = -1; dy <= 1; ++dy)
  {
    const bool rowInside = y + dy * step >= 0 && y + dy * step < height;
    for (int dx = -1; dx <= 1; ++dx)
    {
      if (dx == 0 && dy == 0)
      {
        continue;
      }
      tapColumn[tap] = dx * step;
      tapOffset[tap] = rowInside ? (static_cast<std::ptrdiff_t>(dy) * width + dx) * step : 0;
      tapKernel[tap] = rowInside ? kernel[dx + 1] * kernel[dy + 1] : 0.0f;
      ++tap;
    }
  }

  // The span in chunks, each in two passes. First a loop per tap computes the eight taps'
  // exponents of the guide (albedo, normal, depth: waveletGeometricExponent) into the scratch;
  // then one loop takes each pixel's nine taps, adds the luminance and coverage terms to those
  // exponents and sums the taps with their sums in registers. In one pass GCC kept a pointer to
  // every plane for every tap (72 for the guide alone), most of them on the stack and reloaded
  // before each load (perf put a quarter of the filter's samples on the stack); a loop per tap
  // reads 19 planes. The chunk's exponents, 16 KB, stay in the L1 cache for the second pass.
  // Every result is bit for bit what one pass computed, and the filter takes about 1.5 ms less
  // a stereo pair at 1440x936 (Documentation/Denoising.md, "Changes, measured").
  float* __restrict geometric = scratch.data() + 2 * static_cast<std::size_t>(count);
  for (int chunkBegin = 0; chunkBegin < count; chunkBegin += chunk)
  {
    const int chunkCount = std::min(chunk, count - chunkBegin);
    const std::size_t chunkRow = row + chunkBegin;
    auto exponentsOfTap = [&](int t) HV_ALWAYS_INLINE
    {
      float* __restrict tapExponent = geometric + t * chunk;
      auto geometricPixel = [&](int x, const std::ptrdiff_t(&offset)[1], const float(&)[1])
                              HV_ALWAYS_INLINE
      {
        const std::size_t i = chunkRow + x;
        const std::size_t j = i + offset[0];
        tapExponent[x] =
          waveletGeometricExponent(depth[i], spread[i], gradient[i], glm::vec3(nx[i], ny[i], nz[i]),
            glm::vec3(ax[i], ay[i], az[i]), depth[j], spread[j], gradient[j],
            glm::vec3(nx[j], ny[j], nz[j]), glm::vec3(ax[j], ay[j], az[j]), inverseAlbedo, edges);
      };
      const int column[1] = { tapColumn[t] };
      const std::ptrdiff_t offset[1] = { tapOffset[t] };
      const float weight[1] = { tapKernel[t] };
      forStencilOfSpan(
        begin + chunkBegin, chunkCount, width, step, column, offset, weight, geometricPixel);
    };
    // Written out, here and for the taps below: GCC 12 vectorises a pixel loop only once no
    // loop is left inside it.
    exponentsOfTap(0);
    exponentsOfTap(1);
    exponentsOfTap(2);
    exponentsOfTap(3);
    exponentsOfTap(4);
    exponentsOfTap(5);
    exponentsOfTap(6);
    exponentsOfTap(7);

    auto filterPixel = [&](int x, const std::ptrdiff_t(&offset)[8], const float(&k)[8])
                         HV_ALWAYS_INLINE
    {
      const std::size_t i = chunkRow + x;
      const float blurred =
        blurredVariance[chunkBegin + x] / glm::max(blurWeight[chunkBegin + x], 1e-12f);
      const float luminanceScale = 1.0f / (luminanceSigma * std::sqrt(blurred) + 1e-6f);
      const float centreLuminance = luminance(glm::vec3(r[i], g[i], b[i]));
      // The centre tap, whose edge-stopping weight is 1.
      const float centreWeight = kernel[1] * kernel[1];
      float redSum = centreWeight * r[i];
      float greenSum = centreWeight * g[i];
      float blueSum = centreWeight * b[i];
      float coverageSum = centreWeight * a[i];
      float varianceSum = centreWeight * centreWeight * variance[i];
      float weightSum = centreWeight;
      auto addTap = [&](int t) HV_ALWAYS_INLINE
      {
        const std::size_t j = i + offset[t];
        const float w = k[t] * valid[j] *
          waveletWeightOfExponents(geometric[t * chunk + x],
            fabsf(centreLuminance - luminance(glm::vec3(r[j], g[j], b[j]))) * luminanceScale,
            (a[i] - a[j]) * (a[i] - a[j]) * coverageSharpness[i]);
        redSum += w * r[j];
        greenSum += w * g[j];
        blueSum += w * b[j];
        coverageSum += w * a[j];
        varianceSum += w * w * variance[j];
        weightSum += w;
      };
      addTap(0);
      addTap(1);
      addTap(2);
      addTap(3);
      addTap(4);
      addTap(5);
      addTap(6);
      addTap(7);
      // Unseen pixels keep their value (weightSum holds the centre tap's weight there too). A
      // product with 0 or 1, not a select: for AVX2 and AVX-512, GCC 12 leaves a branch for the
      // select, which keeps the loop scalar. All terms are finite, so the other one adds
      // exactly 0.
      const float seen = valid[i] > 0.0f ? 1.0f : 0.0f;
      const float unseen = 1.0f - seen;
      filteredRed[i] = seen * (redSum / weightSum) + unseen * r[i];
      filteredGreen[i] = seen * (greenSum / weightSum) + unseen * g[i];
      filteredBlue[i] = seen * (blueSum / weightSum) + unseen * b[i];
      filteredCoverage[i] = seen * (coverageSum / weightSum) + unseen * a[i];
      filteredVariance[i] = seen * (varianceSum / (weightSum * weightSum));
    };
    // forStencilOfSpan is inlined, so its loops over the pixels vectorise as if written here;
    // a closure that wraps the per-pixel lambdas would keep GCC from vectorising them.
    forStencilOfSpan(
      begin + chunkBegin, chunkCount, width, step, tapColumn, tapOffset, tapKernel, filterPixel);
  }
}
}
}
}
