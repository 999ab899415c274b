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
  glm::vec3 meanRadiance = glm::vec3(1.0f); // over the sphere, before scale
  float scale = 1.0f;              // multiplies every radiance value
  Distribution2DView distribution; // over luminance * sin(theta); empty when uniform
  bool importanceSampling = true;

  HV_FUNCTION bool isUniform() const { return this->radiance == nullptr; }

  // The radiance a white isotropic medium would scatter on average: (1 / 4 pi) times the
  // integral of L over the sphere.
  HV_FUNCTION glm::vec3 averageRadiance() const { return this->scale * this->meanRadiance; }

  HV_FUNCTION const float* texelAddress(const glm::vec2& uv) const
  {
    const int column = glm::clamp(static_cast<int>(uv.x * this->width), 0, this->width - 1);
    const int row = glm::clamp(static_cast<int>(uv.y * this->height), 0, this->height - 1);
    return this->radiance + 3 * (static_cast<long>(row) * this->width + column);
  }

  HV_FUNCTION glm::vec3 texel(const glm::vec2& uv) const
  {
    const float* value = this->texelAddress(uv);
    return this->scale * glm::vec3(value[0], value[1], value[2]);
  }

  // Map coordinates of a world direction; any value for a uniform environment.
  HV_FUNCTION glm::vec2 mapCoordinates(const glm::vec3& worldDirection) const
  {
    return this->isUniform() ? glm::vec2(0.0f)
                             : directionToEquirectangular(this->worldToMap * worldDirection);
  }

  // The radiance at map coordinates from mapCoordinates() or sampleDirection().
  HV_FUNCTION glm::vec3 radianceAt(const glm::vec2& uv) const
  {
    return this->isUniform() ? this->scale * this->uniformRadiance : this->texel(uv);
  }

  // Starts loading the texel at uv: the map is megabytes, so a texel read that has to wait
  // for memory is worth overlapping with tracing the ray that decides whether it is needed.
  HV_FUNCTION void prefetch(const glm::vec2& uv) const
  {
    if (!this->isUniform())
    {
      HV_PREFETCH(this->texelAddress(uv));
    }
  }

  HV_FUNCTION glm::vec3 evaluate(const glm::vec3& worldDirection) const
  {
    if (this->isUniform())
    {
      return this->scale * this->uniformRadiance;
    }
    return this->texel(directionToEquirectangular(this->worldToMap * worldDirection));
  }

  // evaluate() and pdf() together, mapping the direction to the map once.
  HV_FUNCTION glm::vec3 evaluate(const glm::vec3& worldDirection, float& solidAnglePdf) const
  {
    if (this->isUniform())
    {
      solidAnglePdf = InvFourPi;
      return this->scale * this->uniformRadiance;
    }
    const glm::vec2 uv = directionToEquirectangular(this->worldToMap * worldDirection);
    solidAnglePdf = this->pdfAt(uv);
    return this->texel(uv);
  }

  // Solid-angle density of sampleDirection(). With importance sampling:
  // pdf(omega) = pdf(u, v) / (2 pi^2 sin(theta)) (Pharr et al., PBR 3rd ed., Eq. 14.14).
  HV_FUNCTION float pdf(const glm::vec3& worldDirection) const
  {
    if (this->isUniform() || !this->importanceSampling || !this->distribution.valid())
    {
      return InvFourPi;
    }
    return this->pdfAt(directionToEquirectangular(this->worldToMap * worldDirection));
  }

  HV_FUNCTION float pdfAt(const glm::vec2& uv) const
  {
    if (!this->importanceSampling || !this->distribution.valid())
    {
      return InvFourPi;
    }
    const float sinTheta = glm::sin(uv.y * Pi);
    if (sinTheta <= 1e-6f)
    {
      return 0.0f;
    }
    return this->distribution.pdf(uv) / (2.0f * Pi * Pi * sinTheta);
  }

  HV_FUNCTION glm::vec3 sampleDirection(float u1, float u2, float u3, float& solidAnglePdf) const
  {
    glm::vec2 uvUnused;
    return this->sampleDirection(u1, u2, u3, solidAnglePdf, uvUnused);
  }

  // Also returns the map coordinates of the sampled direction, for radianceAt(), without
  // mapping the direction back.
  HV_FUNCTION glm::vec3 sampleDirection(
    float u1, float u2, float u3, float& solidAnglePdf, glm::vec2& uv) const
  {
    if (this->isUniform() || !this->importanceSampling || !this->distribution.valid())
    {
      solidAnglePdf = InvFourPi;
      const glm::vec3 direction = sampleUniformSphere(u1, u2);
      uv = this->mapCoordinates(direction);
      return direction;
    }
    float uvPdf = 0.0f;
    uv = this->distribution.sample(u1, u2, u3, uvPdf);
    const float sinTheta = glm::sin(uv.y * Pi);
    solidAnglePdf = sinTheta > 1e-6f ? uvPdf / (2.0f * Pi * Pi * sinTheta) : 0.0f;
    return this->mapToWorld * equirectangularToDirection(uv);
  }
};
}

#endif
