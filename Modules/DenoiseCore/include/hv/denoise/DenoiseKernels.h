// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Per-pixel functions of the stereo spatio-temporal denoiser (the paper's Section 3.2). They
// compile for the host and, under nvcc, for the device (see cuda/DenoisePixelDevice.cu): no
// virtual calls, exceptions or STL containers.
#ifndef hv_denoise_DenoiseKernels_h
#define hv_denoise_DenoiseKernels_h

#include "hv/Platform.h"

#include <cstdint>

namespace hv
{
namespace denoise
{
// What the denoiser knows about the surface a pixel sees: its first scatter point (Eq. 2
// reprojects through it) and the local optical state there.
struct Surface
{
  glm::vec3 firstScatterPosition = glm::vec3(0.0f);
  float depth = 0.0f; // eye-space distance along the viewing axis
  glm::vec3 normal = glm::vec3(0.0f);
  float gradientMagnitude = 0.0f; // normalised to [0, 1]
  glm::vec3 albedo = glm::vec3(0.0f);
  // Standard deviation of the depth over the 3x3 neighbourhood. Inside semi-transparent
  // material the first scatter point is a random depth along the ray, so depths of the same
  // structure differ by about this much; at an opaque surface it is the slope's spread only.
  float depthSpread = 0.0f;
  // None: no path of this pixel scattered (background). Own: the pixel's first scatter point.
  // Borrowed: no sample scattered this frame but a neighbour's did, so the pixel (a partly
  // covered silhouette pixel) is filtered and reprojected with the neighbour's surface.
  std::uint32_t kind = 0;
};

enum SurfaceKind : std::uint32_t
{
  SurfaceNone = 0,
  SurfaceOwn = 1,
  SurfaceBorrowed = 2
};

// Weights of the cross-view bilateral filter (zeta), the disocclusion tests and the
// edge-stopping functions of the wavelet filter.
struct EdgeStopping
{
  float albedoSigma = 0.1f;      // exp(-|d albedo|^2 / (2 sigma^2))
  float normalSharpness = 16.0f; // exp(-k (1 - n.n') min(g, g')): only where a gradient exists
  float depthSigma = 0.02f;      // exp(-|dz| / (sigma z)): relative depth difference
};

// How far apart two depths of the same structure may lie by chance: the smaller depth spread
// of the two, where neither point sits on a surface (a strong gradient makes the scatter
// point deterministic, and a silhouette's spread is geometry, not noise).
HV_FUNCTION float depthSlack(float spreadA, float gradientA, float spreadB, float gradientB)
{
  return glm::min(spreadA, spreadB) * (1.0f - glm::max(gradientA, gradientB));
}

// Continuous pixel position and view depth of a world point in an eye; false behind it or
// off-screen. Pixel centres sit at i + 0.5 (hv::EyeView's convention).
HV_FUNCTION bool projectToPixel(const glm::mat4& viewProjection, const glm::mat4& view, int width,
  int height, const glm::vec3& world, glm::vec2& pixel, float& viewDepth)
{
  const glm::vec4 clip = viewProjection * glm::vec4(world, 1.0f);
  if (!(clip.w > 0.0f))
  {
    return false;
  }
  const float inverseW = 1.0f / clip.w;
  pixel.x = 0.5f * (clip.x * inverseW + 1.0f) * static_cast<float>(width);
  pixel.y = 0.5f * (clip.y * inverseW + 1.0f) * static_cast<float>(height);
  viewDepth = -(view[0][2] * world.x + view[1][2] * world.y + view[2][2] * world.z + view[3][2]);
  return pixel.x >= 0.0f && pixel.y >= 0.0f && pixel.x < static_cast<float>(width) &&
    pixel.y < static_cast<float>(height);
}

// zeta: the bilateral weight between the surfaces seen by two pixels (the paper weights by
// the albedo, the gradient at x and the z-depth of x). The normal term only counts where both
// points have a gradient: inside homogeneous material the gradient direction is noise.
HV_FUNCTION float bilateralWeight(const Surface& a, const Surface& b, const EdgeStopping& e)
{
  const glm::vec3 albedoDifference = a.albedo - b.albedo;
  const float albedoTerm = glm::dot(albedoDifference, albedoDifference) /
    (2.0f * e.albedoSigma * e.albedoSigma + 1e-12f);
  const float gradient = glm::min(a.gradientMagnitude, b.gradientMagnitude);
  const float normalTerm =
    e.normalSharpness * glm::max(0.0f, 1.0f - glm::dot(a.normal, b.normal)) * gradient;
  const float depthTerm = glm::abs(a.depth - b.depth) /
    (e.depthSigma * glm::max(a.depth, 1e-6f) +
      depthSlack(a.depthSpread, a.gradientMagnitude, b.depthSpread, b.gradientMagnitude) + 1e-12f);
  return glm::exp(-(albedoTerm + normalTerm + depthTerm));
}

// Whether the surface stored in another view (or frame) at the reprojected pixel is the one
// reprojected there, not an occluder or a different layer: the depth of the reprojected point
// in that view must match the stored depth, within the relative tolerance plus twice the
// depth slack (the stochastic first-scatter depth inside translucent material),
// and where both have a gradient the normals must agree. A failure is a disocclusion.
HV_FUNCTION bool consistentSurface(const Surface& stored, float reprojectedDepth,
  const glm::vec3& normal, float gradientMagnitude, float depthSpread, float depthTolerance,
  float normalCosine)
{
  if (stored.kind == SurfaceNone)
  {
    return false;
  }
  const float slack =
    2.0f * depthSlack(stored.depthSpread, stored.gradientMagnitude, depthSpread, gradientMagnitude);
  if (glm::abs(stored.depth - reprojectedDepth) >
    depthTolerance * glm::max(reprojectedDepth, 1e-6f) + slack)
  {
    return false;
  }
  if (glm::min(stored.gradientMagnitude, gradientMagnitude) > 0.1f &&
    glm::dot(stored.normal, normal) < normalCosine)
  {
    return false;
  }
  return true;
}

// delta(1 / (T - 1)): the sigmoid of the paper's temporal weight w_v = delta(1/(T-1)) zeta,
// delta(u) = 1 / (1 + exp(-steepness (u - centre))). 1/(T - 1) runs from -1 (T = 0, no
// change) to -infinity (T -> 1), so the weight falls as the lighting changes. T outside
// [0, 1) is clamped; NaN counts as a full change (history dropped), the safe side.
HV_FUNCTION float temporalGate(float illuminationDifference, float steepness, float centre)
{
  float t = illuminationDifference;
  if (!(t >= 0.0f))
  {
    t = t < 0.0f ? 0.0f : 1.0f; // negative -> 0, NaN -> 1
  }
  if (t >= 1.0f - 1e-6f)
  {
    return 0.0f;
  }
  const float u = 1.0f / (t - 1.0f);
  const float exponent = clampf(-steepness * (u - centre), -80.0f, 80.0f);
  return 1.0f / (1.0f + glm::exp(exponent));
}

// The paper's D2 weight: lambda = alpha (beta - exp(-|gamma_L - gamma_R|)), gamma the albedo.
// Equal albedo gives alpha (beta - 1) (0.5 with the defaults: both eyes count equally), very
// different albedo alpha beta (1: the eye keeps its own value). Clamped to [0, 1] so that
// other alpha and beta never extrapolate.
HV_FUNCTION float stereoBlendWeight(
  const glm::vec3& albedo, const glm::vec3& otherAlbedo, float alpha, float beta)
{
  const float lambda = alpha * (beta - glm::exp(-glm::length(albedo - otherAlbedo)));
  return clampf(lambda, 0.0f, 1.0f);
}

// Albedo demodulation (Schied et al. 2017): filtering the incident-light factor keeps texture
// detail that the filter would otherwise blur. Channels with (almost) no albedo keep the
// radiance as is, which re-modulation then reverses exactly.
HV_FUNCTION glm::vec4 demodulate(const glm::vec4& radiance, const glm::vec3& albedo)
{
  constexpr float floor = 1e-3f;
  return glm::vec4(albedo.x > floor ? radiance.x / albedo.x : radiance.x,
    albedo.y > floor ? radiance.y / albedo.y : radiance.y,
    albedo.z > floor ? radiance.z / albedo.z : radiance.z, radiance.w);
}

HV_FUNCTION glm::vec4 remodulate(const glm::vec4& signal, const glm::vec3& albedo)
{
  constexpr float floor = 1e-3f;
  return glm::vec4(albedo.x > floor ? signal.x * albedo.x : signal.x,
    albedo.y > floor ? signal.y * albedo.y : signal.y,
    albedo.z > floor ? signal.z * albedo.z : signal.z, signal.w);
}

// Edge-stopping weight of one tap of the a-trous wavelet filter (Dammertz et al. 2010, with
// SVGF's variance-guided luminance term, Schied et al. 2017, Eq. 3-5): depth, normal and
// albedo as in zeta, and luminance relative to the standard deviation of the filtered value.
HV_FUNCTION float waveletWeight(const Surface& centre, const Surface& tap, float centreLuminance,
  float tapLuminance, float luminanceScale, const EdgeStopping& e)
{
  const glm::vec3 albedoDifference = centre.albedo - tap.albedo;
  const float albedoTerm = glm::dot(albedoDifference, albedoDifference) /
    (2.0f * e.albedoSigma * e.albedoSigma + 1e-12f);
  const float gradient = glm::min(centre.gradientMagnitude, tap.gradientMagnitude);
  const float normalTerm =
    e.normalSharpness * glm::max(0.0f, 1.0f - glm::dot(centre.normal, tap.normal)) * gradient;
  const float depthTerm = glm::abs(centre.depth - tap.depth) /
    (e.depthSigma * glm::max(centre.depth, 1e-6f) +
      depthSlack(centre.depthSpread, centre.gradientMagnitude, tap.depthSpread,
        tap.gradientMagnitude) +
      1e-12f);
  const float luminanceTerm = glm::abs(centreLuminance - tapLuminance) * luminanceScale;
  return glm::exp(-(albedoTerm + normalTerm + depthTerm + luminanceTerm));
}

// Neighbourhood clamping of the reprojected history (Karis 2014; Salvi's variance box): the
// history is limited to mean +- width * standard deviation of the current neighbourhood,
// which removes ghosts that reprojection and T do not catch.
HV_FUNCTION glm::vec4 clampToNeighbourhood(
  const glm::vec4& history, const glm::vec4& mean, const glm::vec4& standardDeviation, float width)
{
  return glm::clamp(history, mean - width * standardDeviation, mean + width * standardDeviation);
}
}
}

#endif
