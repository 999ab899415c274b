// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Shared helpers of the kernel unit tests: running statistics and small volume builders.
#ifndef hv_KernelTestUtilities_h
#define hv_KernelTestUtilities_h

#include "hv/Render.h"
#include "hv/VolumeGrid.h"

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
}

#endif
