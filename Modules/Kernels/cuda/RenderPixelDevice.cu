// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Instantiates the per-pixel path-tracing kernel as CUDA device code. It proves that the
// kernels stay device-compilable (no virtuals, exceptions or STL inside); the CUDA backend
// that launches it comes later.
#include "hv/Render.h"

namespace hv
{
__global__ void renderEyeKernel(SceneView scene, EyeView eye, unsigned int eyeIndex,
  unsigned int frameIndex, unsigned long long seed, int samplesPerPixel, PixelResult* pixels)
{
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= eye.width || y >= eye.height)
  {
    return;
  }
  pixels[y * eye.width + x] =
    renderPixel(scene, eye, x, y, eyeIndex, frameIndex, seed, samplesPerPixel);
}
}
