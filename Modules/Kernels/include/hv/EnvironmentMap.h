// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_EnvironmentMap_h
#define hv_EnvironmentMap_h

#include "hv/Environment.h"

#include <string>
#include <vector>

namespace hv
{
// Host-side piecewise-constant 2D distribution; view() is what kernels sample.
class Distribution2D
{
public:
  // f: width * height non-negative values, row-major.
  void build(int width, int height, std::vector<float> f);
  Distribution2DView view() const;

private:
  int Width = 0;
  int Height = 0;
  std::vector<float> Function;
  std::vector<AliasEntry> Table;
  float Integral = 0.0f;
};

// Host-side environment: an equirectangular radiance map (row 0 at the zenith) with its
// importance-sampling distribution (luminance * sin(theta)) and its order-2 spherical
// harmonic projection, or a uniform radiance when no map is set.
class EnvironmentMap
{
public:
  // Returns an empty string on success, otherwise what is wrong with the map (aspect ratio,
  // non-finite or negative texels) so the caller can tell the user.
  std::string setRadiance(int width, int height, std::vector<float> rgb);
  void clearRadiance();
  void setUniformRadiance(const glm::vec3& radiance) { this->UniformRadiance = radiance; }
  void setWorldToMap(const glm::mat3& rotation);
  void setScale(float scale) { this->Scale = scale; }
  void setImportanceSampling(bool enabled) { this->ImportanceSampling = enabled; }

  // Radiance coefficients L_lm in the map frame (uniform: only L_00 non-zero).
  void sphericalHarmonics(glm::vec3 coefficients[9]) const;

  EnvironmentView view() const;

private:
  int Width = 0;
  int Height = 0;
  std::vector<float> Radiance;
  Distribution2D Distribution;
  glm::vec3 SH[9];
  glm::vec3 UniformRadiance = glm::vec3(1.0f);
  glm::mat3 WorldToMap = glm::mat3(1.0f);
  float Scale = 1.0f;
  bool ImportanceSampling = true;
};

// Real spherical harmonics basis up to order 2 in the order used by irradianceFromSH.
void evaluateSHBasis(const glm::vec3& direction, float basis[9]);
}

#endif
