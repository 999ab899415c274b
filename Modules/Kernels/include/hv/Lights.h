// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_Lights_h
#define hv_Lights_h

#include "hv/Platform.h"

namespace hv
{
constexpr int MaximumLights = 8;

enum LightType : int
{
  DirectionalLight = 0,
  PositionalLight = 1
};

// A VTK light in world space. `intensity` is VTK's intensity times its colour.
struct PointLightView
{
  int type = DirectionalLight;
  glm::vec3 position = glm::vec3(0.0f);   // positional lights
  glm::vec3 toLight = glm::vec3(0, 0, 1); // directional lights: unit vector towards the light
  glm::vec3 spotDirection = glm::vec3(0, 0, -1); // unit, from the light to its focal point
  glm::vec3 intensity = glm::vec3(1.0f);
  glm::vec3 attenuation = glm::vec3(1.0f, 0.0f, 0.0f); // VTK's constant, linear, quadratic
  float spotCosCutoff = -1.0f; // cos of VTK's cone angle; -1 disables the spot
  float spotExponent = 1.0f;
};

// Direction towards the light, distance to it (Infinity for directional lights) and the
// VTK-style intensity arriving at x after attenuation and spot falloff (no occlusion).
HV_FUNCTION glm::vec3 evaluateLight(
  const PointLightView& light, const glm::vec3& x, glm::vec3& toLight, float& distance)
{
  if (light.type == DirectionalLight)
  {
    toLight = light.toLight;
    distance = Infinity;
    return light.intensity;
  }
  const glm::vec3 offset = light.position - x;
  distance = glm::length(offset);
  toLight = distance > 0.0f ? offset / distance : glm::vec3(0, 0, 1);
  const float falloff =
    light.attenuation.x + distance * (light.attenuation.y + distance * light.attenuation.z);
  glm::vec3 result = light.intensity / glm::max(falloff, 1e-6f);
  if (light.spotCosCutoff > -1.0f)
  {
    const float cosAngle = glm::dot(-toLight, light.spotDirection);
    result *= cosAngle < light.spotCosCutoff
      ? 0.0f
      : glm::pow(glm::max(cosAngle, 0.0f), light.spotExponent);
  }
  return result;
}
}

#endif
