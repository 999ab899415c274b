// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Instantiates the denoiser's per-pixel functions as CUDA device code: cross-view
// reprojection with its disocclusion test and zeta, w_v's sigmoid, one a-trous tap, D2's
// blend and the Catmull-Rom history fetch. It proves they stay device-compilable; a CUDA backend
// that launches them comes later.
#include "hv/denoise/DenoiseKernels.h"

namespace hv
{
namespace denoise
{
// One eye's D2 on the device, and the weights zeta, w_v's sigmoid and an a-trous tap of the
// same pixel pair, written out as a GPU implementation would use them.
__global__ void stereoBlendKernel(const Surface* left, const Surface* right,
  const glm::vec4* leftD1, const glm::vec4* rightD1, glm::mat4 rightViewProjection,
  glm::mat4 rightView, int width, int height, float illuminationDifference, EdgeStopping edges,
  glm::vec4* out, glm::vec4* weights)
{
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= width || y >= height)
  {
    return;
  }
  const int i = y * width + x;
  const Surface& s = left[i];
  glm::vec4 value = leftD1[i];
  glm::vec4 w(0.0f);
  glm::vec2 pixel;
  float depth;
  if (s.kind != SurfaceNone &&
    projectToPixel(rightViewProjection, rightView, width, height, s.firstScatterPosition, pixel, depth))
  {
    const int q = static_cast<int>(pixel.y) * width + static_cast<int>(pixel.x);
    if (consistentSurface(
          right[q], depth, s.normal, s.gradientMagnitude, s.depthSpread, 0.03f, 0.5f, 0.3f))
    {
      const float lambda = stereoBlendWeight(s.albedo, right[q].albedo, 0.5f, 2.0f);
      const float otherWeight = (1.0f - lambda) *
        stereoAgreement(
          luminance(glm::vec3(value)) - luminance(glm::vec3(rightD1[q])), 0.01f, 3.0f);
      value = (1.0f - otherWeight) * value + otherWeight * rightD1[q];
      // The other eye's weight in the cross-view samples, and the wavelet filter's coverage
      // sharpness, as the CPU path computes them.
      w = glm::vec4(bilateralWeight(s, right[q], edges) *
          crossViewCoverage(leftD1[i].w, 8.0f, rightD1[q].w, 8.0f, 1.0f) *
          exponentialOfNegative(coverageSharpness(leftD1[i].w, 8.0f, 2.0f) *
            (leftD1[i].w - rightD1[q].w) * (leftD1[i].w - rightD1[q].w)),
        temporalGate(illuminationDifference, 20.0f, -1.25f),
        waveletWeight(
          s, right[q], luminance(glm::vec3(value)), luminance(glm::vec3(rightD1[q])), 2.0f, edges),
        lambda);
    }
  }
  out[i] = clampToNeighbourhood(remodulate(demodulate(value, s.albedo), s.albedo), leftD1[i],
    glm::vec4(1.0f), 2.0f);
  weights[i] = w;
}

// The history fetched at a sub-pixel position with Catmull-Rom weights (the separable 4x4
// fetch of the CPU path), where the taps lie inside the image.
__global__ void bicubicHistoryKernel(
  const glm::vec4* history, const glm::vec2* positions, int width, int height, glm::vec4* out)
{
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= width || y >= height)
  {
    return;
  }
  const int i = y * width + x;
  const float fx = positions[i].x - 0.5f;
  const float fy = positions[i].y - 0.5f;
  const int x0 = static_cast<int>(floorf(fx));
  const int y0 = static_cast<int>(floorf(fy));
  glm::vec4 sum(0.0f);
  if (x0 >= 1 && y0 >= 1 && x0 + 2 < width && y0 + 2 < height)
  {
    float wx[4], wy[4];
    catmullRomWeights(fx - static_cast<float>(x0), wx);
    catmullRomWeights(fy - static_cast<float>(y0), wy);
    for (int j = 0; j < 4; ++j)
    {
      for (int k = 0; k < 4; ++k)
      {
        sum += (wx[k] * wy[j]) * history[(y0 - 1 + j) * width + (x0 - 1 + k)];
      }
    }
  }
  out[i] = sum;
}
}
}
