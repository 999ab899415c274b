// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Instantiates the fisheye lens model of the stitcher (and a whole-eye kernel of the path
// tracer) as CUDA device code, so that they stay device-compilable (no virtuals, exceptions or
// STL inside). The path tracer also runs on a GPU against the host in
// Testing/TestRenderDevice.cu; the fisheye model is compiled only.
#include "hv/Equirectangular.h"
#include "hv/FisheyeLens.h"
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

// The dual-fisheye lens model (hv/FisheyeLens.h): the remap position of each panorama pixel
// in one lens, and the direction back from it, as a GPU stitcher would compute them.
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
