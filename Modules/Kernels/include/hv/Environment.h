// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_Environment_h
#define hv_Environment_h

#include "hv/Distribution.h"
#include "hv/Equirectangular.h"
#include "hv/Sampling.h"

namespace hv
{
// Distant illumination: an equirectangular radiance map (linear RGB, row 0 at the zenith,
// see Equirectangular.h) or, without one, a uniform environment. Texels are looked up
// nearest-neighbour so that radiance and sampling density are the same piecewise-constant
// function, which keeps the importance-sampled estimator's variance low near a small sun.
struct EnvironmentView
{
  const float* radiance = nullptr; // width * height * 3, or nullptr for a uniform environment
  int width = 0;
  int height = 0;
  glm::mat3 worldToMap = glm::mat3(1.0f); // rotation taking world directions into the map frame
  glm::mat3 mapToWorld = glm::mat3(1.0f);
  glm::vec3 uniformRadiance = glm::vec3(1.0f);
  float scale = 1.0f;                  // multiplies every radiance value
  Distribution2DView distribution;     // over luminance * sin(theta); empty when uniform
  bool importanceSampling = true;

  HV_FUNCTION bool isUniform() const { return this->radiance == nullptr; }

  HV_FUNCTION glm::vec3 evaluate(const glm::vec3& worldDirection) const
  {
    if (this->isUniform())
    {
      return this->scale * this->uniformRadiance;
    }
    const glm::vec2 uv = directionToEquirectangular(this->worldToMap * worldDirection);
    const int column = glm::clamp(static_cast<int>(uv.x * this->width), 0, this->width - 1);
    const int row = glm::clamp(static_cast<int>(uv.y * this->height), 0, this->height - 1);
    const float* texel = this->radiance + 3 * (static_cast<long>(row) * this->width + column);
    return this->scale * glm::vec3(texel[0], texel[1], texel[2]);
  }

  // Solid-angle density of sampleDirection(). With importance sampling:
  // pdf(omega) = pdf(u, v) / (2 pi^2 sin(theta)) (Pharr et al., PBR 3rd ed., Eq. 14.14).
  HV_FUNCTION float pdf(const glm::vec3& worldDirection) const
  {
    if (this->isUniform() || !this->importanceSampling || !this->distribution.valid())
    {
      return InvFourPi;
    }
    const glm::vec2 uv = directionToEquirectangular(this->worldToMap * worldDirection);
    const float sinTheta = glm::sin(uv.y * Pi);
    if (sinTheta <= 1e-6f)
    {
      return 0.0f;
    }
    return this->distribution.pdf(uv) / (2.0f * Pi * Pi * sinTheta);
  }

  HV_FUNCTION glm::vec3 sampleDirection(float u1, float u2, float& solidAnglePdf) const
  {
    if (this->isUniform() || !this->importanceSampling || !this->distribution.valid())
    {
      solidAnglePdf = InvFourPi;
      return sampleUniformSphere(u1, u2);
    }
    float uvPdf = 0.0f;
    const glm::vec2 uv = this->distribution.sample(u1, u2, uvPdf);
    const float sinTheta = glm::sin(uv.y * Pi);
    solidAnglePdf = sinTheta > 1e-6f ? uvPdf / (2.0f * Pi * Pi * sinTheta) : 0.0f;
    return this->mapToWorld * equirectangularToDirection(uv);
  }
};
}

#endif
