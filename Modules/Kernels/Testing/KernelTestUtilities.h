// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Shared helpers of the kernel unit tests: running statistics and small volume builders.
#ifndef hv_KernelTestUtilities_h
#define hv_KernelTestUtilities_h

#include "hv/EnvironmentMap.h"
#include "hv/Render.h"
#include "hv/VolumeGrid.h"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <functional>
#include <utility>
#include <vector>

namespace hvtest
{
constexpr double Pi = 3.14159265358979323846;

// Welford's running mean and variance, in double so that millions of samples do not lose
// precision.
class RunningStats
{
public:
  void add(double x)
  {
    ++this->Count;
    const double delta = x - this->Mean;
    this->Mean += delta / static_cast<double>(this->Count);
    this->M2 += delta * (x - this->Mean);
  }
  std::size_t count() const { return this->Count; }
  double mean() const { return this->Mean; }
  // Unbiased sample variance of one sample.
  double variance() const
  {
    return this->Count > 1 ? this->M2 / static_cast<double>(this->Count - 1) : 0.0;
  }
  // Standard error of the mean.
  double standardError() const
  {
    return std::sqrt(this->variance() / static_cast<double>(this->Count));
  }

private:
  std::size_t Count = 0;
  double Mean = 0.0;
  double M2 = 0.0;
};

// A scalar field given as a function of the continuous voxel index, sampled at the voxels.
inline std::vector<float> sampleField(
  const glm::ivec3& dims, const std::function<float(const glm::vec3&)>& f)
{
  std::vector<float> values(static_cast<std::size_t>(dims.x) * dims.y * dims.z);
  std::size_t n = 0;
  for (int k = 0; k < dims.z; ++k)
  {
    for (int j = 0; j < dims.y; ++j)
    {
      for (int i = 0; i < dims.x; ++i)
      {
        values[n++] = f(glm::vec3(i, j, k));
      }
    }
  }
  return values;
}

// A transfer function with the same opacity alpha and albedo everywhere.
inline void setConstantTransferFunction(hv::VolumeGrid& grid, float alpha, const glm::vec3& albedo,
  float unitDistance, float densityScale, int nodes = 2)
{
  std::vector<float> opacity(nodes, alpha);
  std::vector<float> rgb;
  for (int i = 0; i < nodes; ++i)
  {
    rgb.push_back(albedo.x);
    rgb.push_back(albedo.y);
    rgb.push_back(albedo.z);
  }
  grid.setTransferFunction(opacity, rgb, unitDistance, densityScale);
}

// The extinction VolumeGrid documents for opacity alpha per unit distance.
inline double extinctionOf(double alpha, double unitDistance, double densityScale)
{
  return -std::log(1.0 - alpha) / unitDistance * densityScale;
}

// Length of the part of the world ray origin + t * direction (t >= 0, unit direction) inside
// the axis-aligned world box [low, high], computed independently of hv::makeIndexRay.
inline double boxChordLength(const glm::dvec3& origin, const glm::dvec3& direction,
  const glm::dvec3& low, const glm::dvec3& high)
{
  double t0 = 0.0, t1 = 1e300;
  for (int axis = 0; axis < 3; ++axis)
  {
    if (std::abs(direction[axis]) < 1e-300)
    {
      if (origin[axis] < low[axis] || origin[axis] > high[axis])
      {
        return 0.0;
      }
      continue;
    }
    double a = (low[axis] - origin[axis]) / direction[axis];
    double b = (high[axis] - origin[axis]) / direction[axis];
    if (a > b)
    {
      std::swap(a, b);
    }
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  return t1 > t0 ? t1 - t0 : 0.0;
}
// An eye of the given matrices and size, its inverse updated.
inline hv::EyeView makeEye(
  const glm::mat4& view, const glm::mat4& projection, int width, int height)
{
  hv::EyeView eye;
  eye.view = view;
  eye.projection = projection;
  eye.width = width;
  eye.height = height;
  eye.update();
  return eye;
}

// A 24^3 volume on [-0.5, 0.5]^3: a ball of scalar 1 (radius 9 voxels = 0.39) in scalar 0,
// opacity table (0, alpha) so sigmaT = 10 s per world unit: optical radius ~3.9, i.e. tens of
// scattering events per path, and a smooth boundary with strong gradients for surface events.
inline void makeBall(hv::VolumeGrid& grid, const glm::vec3& albedo)
{
  const glm::ivec3 dims(24);
  const float voxel = 1.0f / 23.0f;
  grid.setCellSize(4);
  grid.setIndexToWorld(
    glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(-0.5f)), glm::vec3(voxel)));
  grid.setScalars(dims,
    hvtest::sampleField(dims,
      [](const glm::vec3& p) { return glm::length(p - glm::vec3(11.5f)) <= 9.0f ? 1.0f : 0.0f; }));
  // alpha = 1 - exp(-1) per unit distance 0.1: sigmaT = 10 at s = 1.
  grid.setTransferFunction({ 0.0f, 1.0f - std::exp(-1.0f) },
    { albedo.x, albedo.y, albedo.z, albedo.x, albedo.y, albedo.z }, 0.1f, 1.0f);
}

// A path-traced scene of the grid under the environment, shown behind it (white furnace).
inline hv::SceneView furnaceScene(hv::VolumeGrid& grid, const hv::EnvironmentMap& environment)
{
  hv::SceneView scene;
  scene.volume = grid.view();
  scene.environment = environment.view();
  environment.sphericalHarmonics(scene.irradianceSH);
  scene.model = hv::PathTraced;
  scene.lightCount = 0;
  scene.environmentVisible = true;
  scene.maximumBounces = 1000;
  scene.rouletteStartBounce = 3;
  return scene;
}

// The uniform environment's radiance of the white furnace tests.
const glm::vec3 FurnaceRadiance(0.8f, 1.0f, 1.3f);
}

#endif
