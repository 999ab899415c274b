// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_Sampling_h
#define hv_Sampling_h

#include "hv/Platform.h"

namespace hv
{
// Orthonormal basis around a unit vector (Duff et al. 2017, "Building an Orthonormal Basis,
// Revisited"), branch-free apart from the sign.
HV_FUNCTION void makeBasis(const glm::vec3& n, glm::vec3& tangent, glm::vec3& bitangent)
{
  const float sign = n.z >= 0.0f ? 1.0f : -1.0f;
  const float a = -1.0f / (sign + n.z);
  const float b = n.x * n.y * a;
  tangent = glm::vec3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
  bitangent = glm::vec3(b, sign + n.y * n.y * a, -n.y);
}

HV_FUNCTION glm::vec3 fromLocal(const glm::vec3& local, const glm::vec3& n)
{
  glm::vec3 t, b;
  makeBasis(n, t, b);
  return local.x * t + local.y * b + local.z * n;
}

HV_FUNCTION glm::vec3 sampleUniformSphere(float u1, float u2)
{
  const float z = 1.0f - 2.0f * u1;
  const float r = glm::sqrt(glm::max(0.0f, 1.0f - z * z));
  const float phi = TwoPi * u2;
  return glm::vec3(r * glm::cos(phi), r * glm::sin(phi), z);
}

// Cosine-weighted hemisphere around n; pdf = cos(theta) / pi.
HV_FUNCTION glm::vec3 sampleCosineHemisphere(const glm::vec3& n, float u1, float u2)
{
  const float r = glm::sqrt(u1);
  const float phi = TwoPi * u2;
  const glm::vec3 local(r * glm::cos(phi), r * glm::sin(phi), glm::sqrt(glm::max(0.0f, 1.0f - u1)));
  return fromLocal(local, n);
}

// Henyey-Greenstein phase function. cosTheta is the cosine between the propagation
// directions of the incoming and the scattered light, so g > 0 scatters forward.
// p(cos) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos)^(3/2)), normalised over the sphere.
HV_FUNCTION float henyeyGreenstein(float cosTheta, float g)
{
  const float denominator = 1.0f + g * g - 2.0f * g * cosTheta;
  return InvFourPi * (1.0f - g * g) / (denominator * glm::sqrt(glm::max(denominator, 1e-12f)));
}

// Samples a propagation direction after scattering, given the incoming propagation direction;
// the pdf equals henyeyGreenstein(dot(incoming, result), g). Inverse CDF from Pharr et al.,
// "Physically Based Rendering", 3rd ed., Sec. 15.2.3.
HV_FUNCTION glm::vec3 sampleHenyeyGreenstein(const glm::vec3& incoming, float g, float u1, float u2)
{
  float cosTheta;
  if (glm::abs(g) < 1e-3f)
  {
    cosTheta = 1.0f - 2.0f * u1;
  }
  else
  {
    const float s = (1.0f - g * g) / (1.0f - g + 2.0f * g * u1);
    cosTheta = (1.0f + g * g - s * s) / (2.0f * g);
  }
  cosTheta = clampf(cosTheta, -1.0f, 1.0f);
  const float sinTheta = glm::sqrt(glm::max(0.0f, 1.0f - cosTheta * cosTheta));
  const float phi = TwoPi * u2;
  return fromLocal(
    glm::vec3(sinTheta * glm::cos(phi), sinTheta * glm::sin(phi), cosTheta), incoming);
}

// Veach's power heuristic with beta = 2 for two strategies with one sample each.
HV_FUNCTION float powerHeuristic(float pdfA, float pdfB)
{
  const float a = pdfA * pdfA;
  const float b = pdfB * pdfB;
  return a + b > 0.0f ? a / (a + b) : 0.0f;
}
}

#endif
