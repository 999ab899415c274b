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
HV_WIDEST_VECTORS void filterWaveletRow(const SurfacePlanes& guide, const ColourPlanes& in,
  const std::vector<float>& inVariance, ColourPlanes& out, std::vector<float>& outVariance,
  int width, int height, int y, int begin, int end, int step, float luminanceSigma,
  const EdgeStopping edges)
{
  // The loops are marked ivdep: their planes never overlap (GCC honours __restrict on these
  // local pointers only in part), which is what lets it vectorise them.
  static const float kernel[3] = { 0.25f, 0.5f, 0.25f };
  const int count = end - begin;
  thread_local std::vector<float> scratch;
  scratch.resize(static_cast<std::size_t>(count) * 10);
  std::fill(scratch.begin(), scratch.end(), 0.0f);
  float* __restrict sum[4] = { scratch.data(), scratch.data() + count, scratch.data() + 2 * count,
    scratch.data() + 3 * count };
  float* __restrict varianceSum = scratch.data() + 4 * count;
  float* __restrict weightSum = scratch.data() + 5 * count;
  float* __restrict luminanceScale = scratch.data() + 6 * count;
  float* __restrict centreLuminance = scratch.data() + 7 * count;
  float* __restrict blurWeight = scratch.data() + 8 * count;
  float* __restrict blurredVariance = scratch.data() + 9 * count;
  const std::size_t row = static_cast<std::size_t>(y) * width + begin; // pixel of x = begin

  const float* __restrict valid = guide.valid.data();
  const float* __restrict variance = inVariance.data();
  // SVGF's g3x3: the variance blurred over the seen pixels of the 3x3 neighbourhood.
  for (int dy = -1; dy <= 1; ++dy)
  {
    if (y + dy < 0 || y + dy >= height)
    {
      continue;
    }
    for (int dx = -1; dx <= 1; ++dx)
    {
      const float k = kernel[dx + 1] * kernel[dy + 1];
      const int first = glm::max(0, -dx - begin), last = glm::min(count, width - dx - begin);
      const std::ptrdiff_t offset = static_cast<std::ptrdiff_t>(dy) * width + dx;
#pragma GCC ivdep
      for (int x = first; x < last; ++x)
      {
        const std::size_t j = row + x + offset;
        blurredVariance[x] += k * valid[j] * variance[j];
        blurWeight[x] += k * valid[j];
      }
    }
  }
  const float* __restrict r = in.channel[0].data();
  const float* __restrict g = in.channel[1].data();
  const float* __restrict b = in.channel[2].data();
#pragma GCC ivdep
  for (int x = 0; x < count; ++x)
  {
    const std::size_t i = row + x;
    const float blurred = blurredVariance[x] / glm::max(blurWeight[x], 1e-12f);
    luminanceScale[x] = 1.0f / (luminanceSigma * std::sqrt(blurred) + 1e-6f);
    centreLuminance[x] = luminance(glm::vec3(r[i], g[i], b[i]));
    // The centre tap, whose edge-stopping weight is 1.
    const float w = kernel[1] * kernel[1];
    for (int c = 0; c < 4; ++c)
    {
      sum[c][x] = w * in.channel[c][i];
    }
    varianceSum[x] = w * w * variance[i];
    weightSum[x] = w;
  }

  const float* __restrict depth = guide.depth.data();
  const float* __restrict spread = guide.depthSpread.data();
  const float* __restrict gradient = guide.gradientMagnitude.data();
  const float* __restrict nx = guide.normal[0].data();
  const float* __restrict ny = guide.normal[1].data();
  const float* __restrict nz = guide.normal[2].data();
  const float* __restrict ax = guide.albedo[0].data();
  const float* __restrict ay = guide.albedo[1].data();
  const float* __restrict az = guide.albedo[2].data();
  const float* __restrict a = in.channel[3].data();
  const float* __restrict coverageSharpness = guide.coverageSharpness.data();
  const float inverseAlbedo = inverseTwoSigmaSquared(edges.albedoSigma);
  for (int dy = -1; dy <= 1; ++dy)
  {
    if (y + dy * step < 0 || y + dy * step >= height)
    {
      continue;
    }
    for (int dx = -1; dx <= 1; ++dx)
    {
      if (dx == 0 && dy == 0)
      {
        continue;
      }
      const float k = kernel[dx + 1] * kernel[dy + 1];
      const int first = glm::max(0, -dx * step - begin);
      const int last = glm::min(count, width - dx * step - begin);
      const std::ptrdiff_t offset = (static_cast<std::ptrdiff_t>(dy) * width + dx) * step;
#pragma GCC ivdep
      for (int x = first; x < last; ++x)
      {
        const std::size_t i = row + x;
        const std::size_t j = i + offset;
        const float w = k * valid[j] *
          waveletWeightOfChannels(depth[i], spread[i], gradient[i], glm::vec3(nx[i], ny[i], nz[i]),
            glm::vec3(ax[i], ay[i], az[i]), centreLuminance[x], luminanceScale[x], depth[j],
            spread[j], gradient[j], glm::vec3(nx[j], ny[j], nz[j]), glm::vec3(ax[j], ay[j], az[j]),
            luminance(glm::vec3(r[j], g[j], b[j])), inverseAlbedo, edges,
            (a[i] - a[j]) * (a[i] - a[j]) * coverageSharpness[i]);
        sum[0][x] += w * r[j];
        sum[1][x] += w * g[j];
        sum[2][x] += w * b[j];
        sum[3][x] += w * a[j];
        varianceSum[x] += w * w * variance[j];
        weightSum[x] += w;
      }
    }
  }

  // Unseen pixels keep their value (weightSum holds the centre tap's weight there too).
  for (int c = 0; c < 4; ++c)
  {
    const float* __restrict source = in.channel[c].data();
    float* __restrict target = out.channel[c].data();
    const float* __restrict accumulated = sum[c];
#pragma GCC ivdep
    for (int x = 0; x < count; ++x)
    {
      const std::size_t i = row + x;
      target[i] = valid[i] > 0.0f ? accumulated[x] / weightSum[x] : source[i];
    }
  }
  float* __restrict filteredVariance = outVariance.data();
#pragma GCC ivdep
  for (int x = 0; x < count; ++x)
  {
    const std::size_t i = row + x;
    filteredVariance[i] = valid[i] > 0.0f ? varianceSum[x] / (weightSum[x] * weightSum[x]) : 0.0f;
  }
}
}
}
}
