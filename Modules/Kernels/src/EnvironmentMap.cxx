// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/EnvironmentMap.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace hv
{
void Distribution2D::build(int width, int height, std::vector<float> f)
{
  this->Width = width;
  this->Height = height;
  this->Function = std::move(f);
  this->ConditionalCdf.assign(static_cast<std::size_t>(height) * (width + 1), 0.0f);
  this->RowIntegral.assign(height, 0.0f);
  this->MarginalCdf.assign(height + 1, 0.0f);
  // Accumulate in double: a 2K map has millions of texels and a small sun.
  std::vector<double> rowSum(height, 0.0);
  for (int row = 0; row < height; ++row)
  {
    float* cdf = this->ConditionalCdf.data() + static_cast<std::size_t>(row) * (width + 1);
    double running = 0.0;
    for (int column = 0; column < width; ++column)
    {
      running += this->Function[static_cast<std::size_t>(row) * width + column];
      cdf[column + 1] = static_cast<float>(running);
    }
    rowSum[row] = running;
    this->RowIntegral[row] = static_cast<float>(running / width);
    for (int column = 1; column <= width; ++column)
    {
      cdf[column] = running > 0.0 ? static_cast<float>(cdf[column] / running)
                                  : static_cast<float>(column) / width;
    }
    cdf[width] = 1.0f;
  }
  double total = 0.0;
  for (int row = 0; row < height; ++row)
  {
    total += rowSum[row];
    this->MarginalCdf[row + 1] = static_cast<float>(total);
  }
  for (int row = 1; row <= height; ++row)
  {
    this->MarginalCdf[row] = total > 0.0 ? static_cast<float>(this->MarginalCdf[row] / total)
                                         : static_cast<float>(row) / height;
  }
  this->MarginalCdf[height] = 1.0f;
  this->Integral = static_cast<float>(total / (static_cast<double>(width) * height));
}

Distribution2DView Distribution2D::view() const
{
  Distribution2DView v;
  v.width = this->Width;
  v.height = this->Height;
  v.function = this->Function.empty() ? nullptr : this->Function.data();
  v.conditionalCdf = this->ConditionalCdf.data();
  v.rowIntegral = this->RowIntegral.data();
  v.marginalCdf = this->MarginalCdf.data();
  v.integral = this->Integral;
  return v;
}

void evaluateSHBasis(const glm::vec3& d, float basis[9])
{
  basis[0] = 0.282095f;
  basis[1] = 0.488603f * d.y;
  basis[2] = 0.488603f * d.z;
  basis[3] = 0.488603f * d.x;
  basis[4] = 1.092548f * d.x * d.y;
  basis[5] = 1.092548f * d.y * d.z;
  basis[6] = 0.315392f * (3.0f * d.z * d.z - 1.0f);
  basis[7] = 1.092548f * d.x * d.z;
  basis[8] = 0.546274f * (d.x * d.x - d.y * d.y);
}

std::string EnvironmentMap::setRadiance(int width, int height, std::vector<float> rgb)
{
  std::ostringstream problem;
  if (width <= 0 || height <= 0 || rgb.size() != static_cast<std::size_t>(width) * height * 3)
  {
    problem << "the environment map has " << rgb.size() << " values for " << width << "x" << height
            << " RGB texels";
    return problem.str();
  }
  if (width != 2 * height)
  {
    problem << "the environment map is " << width << "x" << height
            << "; an equirectangular map must be twice as wide as it is high";
    return problem.str();
  }
  std::size_t bad = 0;
  for (float value : rgb)
  {
    if (!std::isfinite(value) || value < 0.0f)
    {
      ++bad;
    }
  }
  if (bad > 0)
  {
    problem << "the environment map has " << bad
            << " NaN, infinite or negative values; repair or clamp the map before using it";
    return problem.str();
  }
  this->Width = width;
  this->Height = height;
  this->Radiance = std::move(rgb);

  // The sampling distribution lives on blocks of texels, at most 256 wide: its CDFs then stay
  // in cache, which matters more than sub-block precision (a sun of a few texels still gets
  // its block's probability; within a block directions are uniform in (u, v), and the pdf
  // below accounts for exactly that, so the estimator stays unbiased).
  // Blocks must tile the map exactly: with a partial block at the border the block weights
  // drift off the texels they stand for, and the sun's probability lands beside the sun
  // (measured: the variance gain over uniform sampling fell from ~1400x to 2.8x).
  int block = std::max(1, width / 256);
  while (block > 1 && (width % block != 0 || height % block != 0))
  {
    --block;
  }
  const int blocksWide = (width + block - 1) / block;
  const int blocksHigh = (height + block - 1) / block;
  std::vector<double> blockWeight(static_cast<std::size_t>(blocksWide) * blocksHigh, 0.0);
  std::vector<int> blockCount(blockWeight.size(), 0);
  const double texelSolidAngleNoSin = (2.0 * Pi / width) * (Pi / height);
  std::vector<glm::dvec3> sh(9, glm::dvec3(0.0));
  for (int row = 0; row < height; ++row)
  {
    const float v = (row + 0.5f) / height;
    const float sinTheta = std::sin(v * Pi);
    for (int column = 0; column < width; ++column)
    {
      const std::size_t texel = static_cast<std::size_t>(row) * width + column;
      const glm::vec3 radiance(
        this->Radiance[3 * texel], this->Radiance[3 * texel + 1], this->Radiance[3 * texel + 2]);
      // Importance weight luminance * sin(theta): the Jacobian of the lat-long mapping.
      const std::size_t target =
        static_cast<std::size_t>(row / block) * blocksWide + column / block;
      blockWeight[target] += luminance(radiance) * sinTheta;
      ++blockCount[target];
      float basis[9];
      evaluateSHBasis(equirectangularToDirection(glm::vec2((column + 0.5f) / width, v)), basis);
      for (int i = 0; i < 9; ++i)
      {
        sh[i] +=
          glm::dvec3(radiance) * static_cast<double>(basis[i] * sinTheta) * texelSolidAngleNoSin;
      }
    }
  }
  for (int i = 0; i < 9; ++i)
  {
    this->SH[i] = glm::vec3(sh[i]);
  }
  std::vector<float> weight(blockWeight.size());
  for (std::size_t i = 0; i < weight.size(); ++i)
  {
    weight[i] = static_cast<float>(blockWeight[i] / std::max(blockCount[i], 1));
  }
  this->Distribution.build(blocksWide, blocksHigh, std::move(weight));
  return std::string();
}

void EnvironmentMap::clearRadiance()
{
  this->Width = 0;
  this->Height = 0;
  this->Radiance.clear();
  this->Distribution = Distribution2D();
}

void EnvironmentMap::setWorldToMap(const glm::mat3& rotation)
{
  this->WorldToMap = rotation;
}

void EnvironmentMap::sphericalHarmonics(glm::vec3 coefficients[9]) const
{
  if (this->Radiance.empty())
  {
    // A uniform radiance L has L_00 = L * sqrt(4 pi).
    coefficients[0] = this->UniformRadiance * std::sqrt(4.0f * Pi);
    for (int i = 1; i < 9; ++i)
    {
      coefficients[i] = glm::vec3(0.0f);
    }
    return;
  }
  for (int i = 0; i < 9; ++i)
  {
    coefficients[i] = this->SH[i];
  }
}

EnvironmentView EnvironmentMap::view() const
{
  EnvironmentView v;
  v.radiance = this->Radiance.empty() ? nullptr : this->Radiance.data();
  v.width = this->Width;
  v.height = this->Height;
  v.worldToMap = this->WorldToMap;
  v.mapToWorld = glm::transpose(this->WorldToMap);
  v.uniformRadiance = this->UniformRadiance;
  v.scale = this->Scale;
  v.distribution = this->Distribution.view();
  v.importanceSampling = this->ImportanceSampling;
  return v;
}
}
