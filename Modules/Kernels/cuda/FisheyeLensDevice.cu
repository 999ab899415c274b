// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Instantiates the stitcher's fisheye lens model as CUDA device code, so that it stays
// device-compilable (no virtuals, exceptions or STL inside). Only compiled: the per-pixel path
// tracer and denoiser run on a GPU against the host in the device tests
// (Testing/TestRenderDevice.cu, DenoiseCore's Testing/TestDenoiseKernelsDevice.cu).
#include "hv/Equirectangular.h"
#include "hv/FisheyeLens.h"

namespace hv
{
__global__ void fisheyeRemapKernel(
  FisheyeLens lens, int width, int height, glm::vec2* positions, glm::vec3* directions)
{
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= width || y >= height)
  {
    return;
  }
  const glm::vec3 direction =
    equirectangularToDirection(glm::vec2((x + 0.5f) / width, (y + 0.5f) / height));
  glm::vec2 pixel;
  const bool inside = fisheyeProjectCamera(lens, direction, pixel);
  glm::vec3 back;
  fisheyeUnproject(lens, pixel, back);
  positions[y * width + x] = inside ? pixel : glm::vec2(-1.0f);
  directions[y * width + x] = back;
}
}
