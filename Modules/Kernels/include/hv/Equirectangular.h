// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_Equirectangular_h
#define hv_Equirectangular_h

#include "hv/Platform.h"

namespace hv
{
// The equirectangular (latitude-longitude) parameterisation used by every HoloVolume
// environment map, in the map's own frame:
//   +Y is the zenith, the image centre (u = 0.5) looks along -Z, u grows towards +X;
//   v = theta / pi with theta the polar angle from +Y, so v = 0 is the top row (zenith).
// A direction d maps to u = 0.5 + atan2(d.x, -d.z) / (2 pi), v = acos(d.y) / pi.
HV_FUNCTION glm::vec2 directionToEquirectangular(const glm::vec3& d)
{
  const float phi = glm::atan(d.x, -d.z); // in (-pi, pi]
  float u = 0.5f + phi * (1.0f / TwoPi);
  u = u >= 1.0f ? u - 1.0f : u;
  const float v = glm::acos(clampf(d.y, -1.0f, 1.0f)) * InvPi;
  return glm::vec2(u, v);
}

HV_FUNCTION glm::vec3 equirectangularToDirection(const glm::vec2& uv)
{
  const float phi = (uv.x - 0.5f) * TwoPi;
  const float theta = uv.y * Pi;
  const float sinTheta = glm::sin(theta);
  return glm::vec3(sinTheta * glm::sin(phi), glm::cos(theta), -sinTheta * glm::cos(phi));
}
}

#endif
