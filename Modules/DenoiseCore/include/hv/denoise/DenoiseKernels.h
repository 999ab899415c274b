// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Per-pixel functions of the stereo spatio-temporal denoiser (the paper's Section 3.2). They
// compile for the host and, under nvcc, for the device, where Testing/TestDenoiseKernelsDevice.cu
// compares them with the host: no virtual calls, exceptions or STL containers.
#ifndef hv_denoise_DenoiseKernels_h
#define hv_denoise_DenoiseKernels_h

#include "hv/Platform.h"

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstring>

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
  // How far this pixel's first scatter depth and normal move from frame to frame by chance,
  // learnt over its history: surfaceJitterTolerance times the RMS of the differences between
  // consecutive frames' scatter points that passed the disocclusion test (depth difference;
  // 1 - cosine of the normals). 0 until the history has one. Inside translucent material a
  // ray scatters at a random depth, where the gradient, and so the normal, is another one
  // each frame; the 3x3 spread misses this where a gradient makes depthSlack 0.
  float depthJitter = 0.0f;
  float normalJitter = 0.0f;
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
  float normalSharpness = 16.0f; // exp(-k (1 - n.n') g): only where a gradient exists
  float depthSigma = 0.02f;      // exp(-|dz| / (sigma z)): relative depth difference
  // g = max(min(g_a, g_b) - normalGradientFloor, 0): the normal term counts only the part of
  // the weaker gradient magnitude above this floor (normalGradient).
  float normalGradientFloor = 0.0f;
  // The albedo term is scaled by 1 - w + w max(g_a, g_b) (albedoGradientScale): with w = 1 it
  // counts in proportion to the larger gradient magnitude, fully where either point sits on a
  // surface and little where both scatter inside tissue. Only the wavelet filter reads it.
  float albedoGradientWeight = 0.0f;
};

// How far apart two depths of the same structure may lie by chance: the smaller depth spread
// of the two, where neither point sits on a surface (a strong gradient makes the scatter
// point deterministic, and a silhouette's spread is geometry, not noise).
HV_FUNCTION float depthSlack(float spreadA, float gradientA, float spreadB, float gradientB)
{
  return glm::min(spreadA, spreadB) * (1.0f - glm::max(gradientA, gradientB));
}

// Continuous pixel position and view depth of a world point in an eye; false behind it or
// off-screen. Pixel centres sit at i + 0.5 (hv::EyeView's convention). Free of branches, so
// that a loop projecting a row of points vectorises: the position and depth are written
// whatever the point (behind the eye they are meaningless, and the result is false).
HV_FUNCTION bool projectToPixel(const glm::mat4& viewProjection, const glm::mat4& view, int width,
  int height, const glm::vec3& world, glm::vec2& pixel, float& viewDepth)
{
  const glm::vec4 clip = viewProjection * glm::vec4(world, 1.0f);
  const float inverseW = 1.0f / clip.w;
  pixel.x = 0.5f * (clip.x * inverseW + 1.0f) * static_cast<float>(width);
  pixel.y = 0.5f * (clip.y * inverseW + 1.0f) * static_cast<float>(height);
  viewDepth = -(view[0][2] * world.x + view[1][2] * world.y + view[2][2] * world.z + view[3][2]);
  return (clip.w > 0.0f) & (pixel.x >= 0.0f) & (pixel.y >= 0.0f) &
    (pixel.x < static_cast<float>(width)) & (pixel.y < static_cast<float>(height));
}

// The point at view depth `viewDepth` on the ray through the centre of pixel (x, y) (row 0 at
// the bottom): the inverse of projectToPixel. The view depth is affine along the segment from
// the near to the far clip point, so it is solved for there. Leaves `point` as it is and returns
// false for a degenerate projection.
HV_FUNCTION bool pointOnPixelRay(const glm::mat4& inverseViewProjection, const glm::mat4& view,
  int x, int y, int width, int height, float viewDepth, glm::vec3& point)
{
  const float ndcX = 2.0f * (static_cast<float>(x) + 0.5f) / static_cast<float>(width) - 1.0f;
  const float ndcY = 2.0f * (static_cast<float>(y) + 0.5f) / static_cast<float>(height) - 1.0f;
  const glm::vec4 nearClip = inverseViewProjection * glm::vec4(ndcX, ndcY, -1.0f, 1.0f);
  const glm::vec4 farClip = inverseViewProjection * glm::vec4(ndcX, ndcY, 1.0f, 1.0f);
  const glm::vec3 nearPoint = glm::vec3(nearClip) / nearClip.w;
  const glm::vec3 farPoint = glm::vec3(farClip) / farClip.w;
  const glm::vec4 viewRow(view[0][2], view[1][2], view[2][2], view[3][2]);
  const float nearDepth = -glm::dot(viewRow, glm::vec4(nearPoint, 1.0f));
  const float farDepth = -glm::dot(viewRow, glm::vec4(farPoint, 1.0f));
  // Selected rather than branched on, so that a loop over a row of pixels vectorises.
  const bool valid = glm::abs(farDepth - nearDepth) > 1e-12f;
  const float t = (viewDepth - nearDepth) / (farDepth - nearDepth);
  const glm::vec3 onRay = nearPoint + t * (farPoint - nearPoint);
  point.x = valid ? onRay.x : point.x;
  point.y = valid ? onRay.y : point.y;
  point.z = valid ? onRay.z : point.z;
  return valid;
}

// 2^-t for t in [0, 125]: t = n + f, n the nearest integer, |f| <= 1/2; 2^-n is built in the
// exponent bits and 2^-f = e^y, y = -f ln 2, by its Taylor series to y^6 (the remainder is
// below |y|^7 / 7! < 2e-7 for |y| <= ln(2)/2). Results below 2^-125 are not flushed to 0.
HV_FUNCTION float twoToTheNegative(float t)
{
  const int n = static_cast<int>(t + 0.5f); // t >= 0: truncation rounds to nearest
  const float y = (static_cast<float>(n) - t) * 0.693147181f;
  const float series = 1.0f +
    y *
      (1.0f +
        y *
          (0.5f +
            y * (1.0f / 6.0f + y * (1.0f / 24.0f + y * (1.0f / 120.0f + y * (1.0f / 720.0f))))));
  const std::int32_t bits = (127 - n) << 23; // the float 2^-n
  float power;
  std::memcpy(&power, &bits, sizeof(power));
  return series * power;
}

// v clamped to [+0, the float whose bits are upperBits], comparing the bit patterns as
// integers: a non-negative float orders as its bits do, and a negative one (-0 too) has the
// sign bit set, a negative integer. glm::min and glm::max give the same values, but they are
// comparisons of floats, and GCC 12 copies the code that follows each of them once for the
// clamped case (jump threading), which a vectorised loop then merges again with masks. In the
// wavelet filter's AVX-512 tap loop these clamps and the weight's cut-off at 30 took some 170
// of its 1107 instructions per 16 pixels; with the clamps as integers (and fabsf there) it has
// 902, and every result is bit for bit the same.
HV_FUNCTION float clampNonNegativeBits(float v, std::int32_t upperBits)
{
  std::int32_t bits;
  std::memcpy(&bits, &v, sizeof(bits));
  bits = glm::min(glm::max(bits, 0), upperBits);
  float clamped;
  std::memcpy(&clamped, &bits, sizeof(clamped));
  return clamped;
}

// max(v, nonNegative) for any v that is not NaN and nonNegative >= +0, as an integer maximum of
// the bit patterns, for the reason clampNonNegativeBits gives: with nonNegative's sign bit
// clear, a negative v (a negative integer) always loses, and non-negative floats order as their
// bits do.
HV_FUNCTION float maxWithNonNegativeBits(float v, float nonNegative)
{
  std::int32_t bits, otherBits;
  std::memcpy(&bits, &v, sizeof(bits));
  std::memcpy(&otherBits, &nonNegative, sizeof(otherBits));
  bits = glm::max(bits, otherBits);
  float larger;
  std::memcpy(&larger, &bits, sizeof(larger));
  return larger;
}

// The gradient magnitude that scales the normal term of zeta and of the wavelet filter's
// edge-stopping: the weaker of the two points' above `floor`. Where the gradient is weak (inside
// translucent tissue above all) the first scatter point lies at a random depth each frame and
// the gradient's direction there is noise (the disocclusion test compares normals only above
// NormalTestGradient for that reason). A normal term scaled by the whole magnitude took that
// noise for edges: the wavelet filter left such pixels unfiltered, and zeta shortened their
// histories.
// The clamp at 0 is an integer maximum of the bits (maxWithNonNegativeBits), so as not to add a
// float comparison to the wavelet filter's tap loop.
HV_FUNCTION float normalGradient(float gradientA, float gradientB, float floor)
{
  return maxWithNonNegativeBits(glm::min(gradientA, gradientB) - floor, 0.0f);
}

// 1 - w + w max(g_a, g_b) for gradient magnitudes >= 0, the wavelet filter's scale of its albedo
// term (EdgeStopping::albedoGradientWeight). Inside translucent tissue the first scatter point
// lies at a random depth, and its albedo is a random sample of the colours of the tissue along
// the ray, different each frame and pixel; where either point sits on a surface (a strong
// gradient makes the scatter point deterministic) its albedo is the surface's. w = 0 gives
// exactly 1 and w = 1 exactly the maximum.
HV_FUNCTION float albedoGradientScale(float gradientA, float gradientB, float weight)
{
  return (1.0f - weight) + weight * maxWithNonNegativeBits(gradientA, gradientB);
}

// The albedo that re-modulates a pixel's filtered incident light when the history keeps a mean
// albedo: the history's mean where the gradient magnitude g is at most gradients.x, the frame's
// own from gradients.y on, linear between (a step at gradients.y, over 1e-6, if y <= x). Inside
// translucent tissue the first scatter albedo is a random sample of the colours along the ray,
// and the frame's brings that noise back into every frame; on a surface it is deterministic,
// and the frame's keeps albedo edges sharp where the mean, resampled bilinearly as the view
// moves, would blur them. Without branches, so that the re-modulation loop vectorises.
HV_FUNCTION glm::vec3 historyRemodulationAlbedo(const glm::vec3& frameAlbedo,
  const glm::vec3& historyAlbedo, float gradientMagnitude, const glm::vec2& gradients)
{
  const float low = glm::min(gradients.x, gradients.y - 1e-6f);
  const float frameShare = glm::clamp((gradientMagnitude - low) / (gradients.y - low), 0.0f, 1.0f);
  // As a weighted sum, not h + s (f - h): exactly the frame's albedo at s = 1.
  return historyAlbedo * (1.0f - frameShare) + frameAlbedo * frameShare;
}

// e^-x for x >= 0 (negative x count as 0), to a relative error below 4e-6 on [0, 86] (the
// float product x log2(e) dominates; the series adds less than 2e-7): 2^-t with t = x log2(e)
// clamped to [0, 125]. Written out rather than calling expf because the wavelet filter
// evaluates it nine times per pixel and level, and only a branch-free inline form lets the
// compiler vectorise that loop: glibc's vector expf (libmvec) is used only under -ffast-math,
// which would also reorder the filter's sums. The per-pixel weights (zeta, D2's lambda) use
// it too: inline, it costs less than a call.
HV_FUNCTION float exponentialOfNegative(float x)
{
#if defined(__CUDA_ARCH__)
  return __expf(-glm::max(x, 0.0f));
#else
  constexpr std::int32_t bitsOf125 = 0x42fa0000; // 125.0f: 2^-125 is still a normal float
  return twoToTheNegative(clampNonNegativeBits(x * 1.44269504f, bitsOf125));
#endif
}

// zeta: the bilateral weight between the surfaces seen by two pixels (the paper weights by
// the albedo, the gradient at x and the z-depth of x). The normal term only counts where both
// points have a gradient: inside homogeneous material the gradient direction is noise.
HV_FUNCTION float bilateralWeight(const Surface& a, const Surface& b, const EdgeStopping& e)
{
  const glm::vec3 albedoDifference = a.albedo - b.albedo;
  const float albedoTerm = glm::dot(albedoDifference, albedoDifference) /
    (2.0f * e.albedoSigma * e.albedoSigma + 1e-12f);
  const float gradient =
    normalGradient(a.gradientMagnitude, b.gradientMagnitude, e.normalGradientFloor);
  const float normalTerm =
    e.normalSharpness * glm::max(0.0f, 1.0f - glm::dot(a.normal, b.normal)) * gradient;
  const float depthTerm = glm::abs(a.depth - b.depth) /
    (e.depthSigma * glm::max(a.depth, 1e-6f) +
      depthSlack(a.depthSpread, a.gradientMagnitude, b.depthSpread, b.gradientMagnitude) + 1e-12f);
  return exponentialOfNegative(albedoTerm + normalTerm + depthTerm);
}

// Catmull-Rom weights of the taps at -1, 0, 1, 2 for a sample at t in [0, 1) past tap 0. The
// cubic interpolates (t = 0 gives tap 0 alone) and reproduces linear ramps; its negative lobes
// keep the detail that a bilinear fetch would blur at every reprojection of a moving view.
HV_FUNCTION void catmullRomWeights(float t, float weights[4])
{
  const float t2 = t * t;
  const float t3 = t2 * t;
  weights[0] = -0.5f * t3 + t2 - 0.5f * t;
  weights[1] = 1.5f * t3 - 2.5f * t2 + 1.0f;
  weights[2] = -1.5f * t3 + 2.0f * t2 + 0.5f * t;
  weights[3] = 0.5f * t3 - 0.5f * t2;
}

// Whether the surface stored in another view (or frame) at the reprojected pixel is the one
// reprojected there, not an occluder or a different layer: the depth of the reprojected point
// in that view must match the stored depth, within the relative tolerance plus twice the
// depth slack plus the stored pixel's learnt depth jitter (both for the stochastic
// first-scatter depth inside translucent material), and where both have a gradient the
// normals must agree within normalCosine or the stored pixel's learnt normal jitter. "Both
// have a gradient" means both gradient magnitudes exceed normalGradient: below it a scatter
// event is mostly a volume event (the mapper's default surface factor 5 makes it a surface
// event with probability 0.39 at 0.1 and 0.78 at 0.3), the gradient's direction does not
// shape the light, and a random scatter point's normal is another one each frame. A failure
// is a disocclusion. consistentSurfaceOfChannels takes the stored surface's channels and has no
// branches, so that a loop over a row that reads the stored surfaces as strided planes vectorises.
HV_FUNCTION bool consistentSurfaceOfChannels(bool storedSeen, float storedDepth,
  float storedDepthSpread, float storedGradient, const glm::vec3& storedNormal,
  float storedDepthJitter, float storedNormalJitter, float reprojectedDepth,
  const glm::vec3& normal, float gradientMagnitude, float depthSpread, float depthTolerance,
  float normalCosine, float normalGradient)
{
  const float slack =
    2.0f * depthSlack(storedDepthSpread, storedGradient, depthSpread, gradientMagnitude) +
    storedDepthJitter;
  const bool depthAgrees = !(glm::abs(storedDepth - reprojectedDepth) >
    depthTolerance * glm::max(reprojectedDepth, 1e-6f) + slack);
  const bool normalsDisagree = (glm::min(storedGradient, gradientMagnitude) > normalGradient) &
    (glm::dot(storedNormal, normal) < glm::min(normalCosine, 1.0f - storedNormalJitter));
  return storedSeen & depthAgrees & !normalsDisagree;
}

HV_FUNCTION bool consistentSurface(const Surface& stored, float reprojectedDepth,
  const glm::vec3& normal, float gradientMagnitude, float depthSpread, float depthTolerance,
  float normalCosine, float normalGradient)
{
  return consistentSurfaceOfChannels(stored.kind != SurfaceNone, stored.depth, stored.depthSpread,
    stored.gradientMagnitude, stored.normal, stored.depthJitter, stored.normalJitter,
    reprojectedDepth, normal, gradientMagnitude, depthSpread, depthTolerance, normalCosine,
    normalGradient);
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

// The share of the history's arc of viewing directions (maximumHistoryAngle) that a pixel keeps
// where the view grazes its surface. Light returned from under the surface of translucent
// tissue has crossed an optical depth that grows as 1 / cos(theta) with the viewing angle theta
// from the normal, and so changes fastest with the view where cos(theta) is small; there a
// turning view's history lags most (the head's edge under an orbit, Documentation/Denoising.md,
// "A narrower arc where the view grazes the surface"). The arc shrinks in proportion to
// |cos(theta)| below 1 / inverseGrazingCosine, to no less than minimumFraction of it, where
// the gradient magnitude reaches surfaceGradient (the normal describes a surface); elsewhere
// the whole arc is kept. surfaceGradient = infinity keeps it everywhere: the caller's way to
// turn this off with the same arithmetic.
HV_FUNCTION float grazingHistoryArc(float viewCosine, float gradientMagnitude,
  float surfaceGradient, float inverseGrazingCosine, float minimumFraction)
{
  const float shrunk =
    glm::clamp(glm::abs(viewCosine) * inverseGrazingCosine, minimumFraction, 1.0f);
  return gradientMagnitude >= surfaceGradient ? shrunk : 1.0f;
}

// The paper's D2 weight: lambda = alpha (beta - exp(-|gamma_L - gamma_R|)), gamma the albedo.
// Equal albedo gives alpha (beta - 1) (0.5 with the defaults: both eyes count equally), very
// different albedo alpha beta (1: the eye keeps its own value). Clamped to [0, 1] so that
// other alpha and beta never extrapolate.
HV_FUNCTION float stereoBlendWeight(
  const glm::vec3& albedo, const glm::vec3& otherAlbedo, float alpha, float beta)
{
  const float lambda = alpha * (beta - exponentialOfNegative(glm::length(albedo - otherAlbedo)));
  return clampf(lambda, 0.0f, 1.0f);
}

// Below this coverage a pixel's colour (radiance / coverage) is not estimated: a pixel that a
// hundredth of its paths hit divides its noise by a hundredth.
constexpr float ColourCoverageFloor = 0.01f;

// D2's blend of two premultiplied RGBA values (radiance premultiplied by coverage, alpha the
// coverage) with coverage and colour apart: the coverage with weight otherCoverageWeight, the
// colour under it (rgb / alpha) with otherColourWeight, and the result premultiplied again.
// At the silhouette each eye sees the edge from its own side, so the point's coverage differs
// between the eyes for real while the tissue's colour there is the same; a blend of the
// premultiplied values could take both only together. Where either coverage is below
// ColourCoverageFloor, the premultiplied values are blended with otherCoverageWeight.
HV_FUNCTION glm::vec4 stereoBlendUnpremultiplied(
  const glm::vec4& own, const glm::vec4& other, float otherColourWeight, float otherCoverageWeight)
{
  const glm::vec4 premultiplied = (1.0f - otherCoverageWeight) * own + otherCoverageWeight * other;
  const glm::vec3 colour =
    (1.0f - otherColourWeight) * glm::vec3(own) / glm::max(own.w, ColourCoverageFloor) +
    otherColourWeight * glm::vec3(other) / glm::max(other.w, ColourCoverageFloor);
  const glm::vec3 recovered = premultiplied.w * colour;
  // Selects per channel, not a branch, so that a row's loop vectorises.
  const bool covered = (own.w > ColourCoverageFloor) & (other.w > ColourCoverageFloor);
  return glm::vec4(covered ? recovered.x : premultiplied.x, covered ? recovered.y : premultiplied.y,
    covered ? recovered.z : premultiplied.z, premultiplied.w);
}

// How far D2 may blend the other eye at a point, beyond the paper's lambda: e^(-d^2 / (2 k^2
// v)), d the difference of the eyes' filtered luminances there, v the sum of their
// variances, k = agreementWidth (0: always 1, the paper's D2). Noise differs between the eyes
// by about sqrt(v) and is what D2 is for; a difference of several standard deviations is
// something else, which lambda ~ 0.5 would put half into each eye as a bias: the view
// dependence of the phase function and the specular lobe (the eyes see a point some
// degrees apart), the other eye's interpolation between pixel centres, a wrong
// correspondence in translucent tissue. The blend becomes v_L + (1 - lambda) a (v_R - v_L).
// stereoAgreementTerm is the formula alone, for agreementWidth > 0 (for a vectorised loop,
// which cannot hold the test; see crossViewCoverageTerm).
HV_FUNCTION float stereoAgreementTerm(
  float luminanceDifference, float varianceSum, float agreementWidth)
{
  return exponentialOfNegative(luminanceDifference * luminanceDifference /
    (2.0f * agreementWidth * agreementWidth * glm::max(varianceSum, 0.0f) + 1e-20f));
}

HV_FUNCTION float stereoAgreement(
  float luminanceDifference, float varianceSum, float agreementWidth)
{
  if (!(agreementWidth > 0.0f))
  {
    return 1.0f;
  }
  return stereoAgreementTerm(luminanceDifference, varianceSum, agreementWidth);
}

// The variance of a pixel's coverage accumulated over `frames` raw frames, a (1 - a) / frames:
// a frame's alpha is the fraction of the pixel's paths that scattered in the volume, Bernoulli
// trials whose variance is at most a (1 - a), for one path (a clamped to [0, 1]).
HV_FUNCTION float coverageVariance(float coverage, float frames)
{
  const float a = clampf(coverage, 0.0f, 1.0f);
  return a * (1.0f - a) / glm::max(frames, 1.0f);
}

// The sharpness of the wavelet filter's coverage edge-stopping term, (a_i - a_j)^2 times
// this, at a pixel whose colour averages `frames` raw frames: 1 / (2 k^2 v), k =
// agreementWidth (0: no term), v the variance of the pixel's accumulated coverage
// (coverageVariance; the radiance is premultiplied, its alpha is the coverage); a is the 3x3
// mean coverage, so that a pixel that all of its few paths hit by chance is not taken for an
// opaque one. Inside translucent material neighbours differ in
// coverage by about sqrt(2 v), noise the filter should average; at the volume's silhouette
// coverage steps from 1 to 0 within a pixel or two, many standard deviations, and averaging it
// would give partly covered pixels their covered neighbours' light (a bright rim) and those
// their darkness.
HV_FUNCTION float coverageSharpness(float coverage, float frames, float agreementWidth)
{
  if (!(agreementWidth > 0.0f))
  {
    return 0.0f;
  }
  return 1.0f /
    (2.0f * agreementWidth * agreementWidth * coverageVariance(coverage, frames) + 1e-12f);
}

// How far the other eye's samples may count in a pixel's cross-view filtering, given the two
// eyes' accumulated coverages at the point (the alpha of their histories, which average
// `samples` and `otherSamples` raw frames): e^(-d^2 / (2 k^2 v)), d the difference of the
// coverages, v the sum of their variances (coverageVariance), k = agreementWidth (0: always 1). The
// radiance is premultiplied, so a sample brings its eye's coverage along. At the volume's
// silhouette the eyes see the edge from two sides (parallax) and their coverages there differ
// systematically, which biased the edge one-sidedly; inside translucent material they differ by
// noise only.
// crossViewCoverageTerm is the formula alone, for agreementWidth > 0: a loop over a row that
// GCC vectorises cannot hold the test (a choice made on a value that is the same for every pixel),
// so the caller makes it.
HV_FUNCTION float crossViewCoverageTerm(
  float coverage, float samples, float otherCoverage, float otherSamples, float agreementWidth)
{
  const float difference = clampf(coverage, 0.0f, 1.0f) - clampf(otherCoverage, 0.0f, 1.0f);
  const float variance =
    coverageVariance(coverage, samples) + coverageVariance(otherCoverage, otherSamples);
  return exponentialOfNegative(
    difference * difference / (2.0f * agreementWidth * agreementWidth * variance + 1e-12f));
}

HV_FUNCTION float crossViewCoverage(
  float coverage, float samples, float otherCoverage, float otherSamples, float agreementWidth)
{
  if (!(agreementWidth > 0.0f))
  {
    return 1.0f;
  }
  return crossViewCoverageTerm(coverage, samples, otherCoverage, otherSamples, agreementWidth);
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
// The arguments are the channels of both surfaces, so that the CPU filter can keep them in
// planes (one array per channel) and evaluate a row of taps as vectors.
// inverseTwoAlbedoSigmaSquared = 1 / (2 sigma_albedo^2); coverageTerm, the coverage edge-
// stopping (a_i - a_j)^2 coverageSharpness(...), adds to the exponent.
// The weight is e^-(exponent), its exponent the sum of the guide's terms (albedo, normal,
// depth: waveletGeometricExponent), the luminance term and the coverage term, in that order;
// waveletWeightOfExponents takes the first as a number, so that the CPU filter can compute the
// guide's terms in loops of their own (src/WaveletFilter.cxx) and get the same bits.
HV_FUNCTION float waveletGeometricExponent(float centreDepth, float centreSpread,
  float centreGradient, const glm::vec3& centreNormal, const glm::vec3& centreAlbedo,
  float tapDepth, float tapSpread, float tapGradient, const glm::vec3& tapNormal,
  const glm::vec3& tapAlbedo, float inverseTwoAlbedoSigmaSquared, const EdgeStopping& e)
{
  const glm::vec3 albedoDifference = centreAlbedo - tapAlbedo;
  const float albedoTerm = glm::dot(albedoDifference, albedoDifference) *
    inverseTwoAlbedoSigmaSquared *
    albedoGradientScale(centreGradient, tapGradient, e.albedoGradientWeight);
  const float gradient = normalGradient(centreGradient, tapGradient, e.normalGradientFloor);
  const float normalTerm =
    e.normalSharpness * glm::max(0.0f, 1.0f - glm::dot(centreNormal, tapNormal)) * gradient;
  // fabsf, not glm::abs: GCC vectorises glm::abs's comparison as a compare, an xor and a masked
  // move, fabsf as one bitwise and.
  const float depthTerm = fabsf(centreDepth - tapDepth) /
    (e.depthSigma * glm::max(centreDepth, 1e-6f) +
      depthSlack(centreSpread, centreGradient, tapSpread, tapGradient) + 1e-12f);
  return albedoTerm + normalTerm + depthTerm;
}

HV_FUNCTION float waveletWeightOfExponents(
  float geometricExponent, float luminanceTerm, float coverageTerm)
{
  // A weight below e^-30 (1e-13) adds nothing a float sum can hold next to the centre tap's
  // 0.25. Zeroing it keeps the weights and their squares (variance propagation) out of the
  // subnormal range, which is slow on x86 and flushed on GPUs (e^-x itself stays normal, its
  // argument clamped at 125 log 2). The cut-off is a product with 0 or 1, not a select of two
  // values: GCC 12 if-converts the select for SSE2 but, for AVX2 and AVX-512, leaves a branch
  // that keeps the whole wavelet loop scalar (2.2x slower than SSE2). The exponent is not
  // clamped at 30 first: that comparison of floats cost the loop as clampNonNegativeBits
  // explains.
  const float exponent = geometricExponent + luminanceTerm + coverageTerm;
  const float keep = exponent < 30.0f ? 1.0f : 0.0f;
  return keep * exponentialOfNegative(exponent);
}

HV_FUNCTION float waveletWeightOfChannels(float centreDepth, float centreSpread,
  float centreGradient, const glm::vec3& centreNormal, const glm::vec3& centreAlbedo,
  float centreLuminance, float luminanceScale, float tapDepth, float tapSpread, float tapGradient,
  const glm::vec3& tapNormal, const glm::vec3& tapAlbedo, float tapLuminance,
  float inverseTwoAlbedoSigmaSquared, const EdgeStopping& e, float coverageTerm = 0.0f)
{
  return waveletWeightOfExponents(
    waveletGeometricExponent(centreDepth, centreSpread, centreGradient, centreNormal, centreAlbedo,
      tapDepth, tapSpread, tapGradient, tapNormal, tapAlbedo, inverseTwoAlbedoSigmaSquared, e),
    fabsf(centreLuminance - tapLuminance) * luminanceScale, coverageTerm);
}

HV_FUNCTION float inverseTwoSigmaSquared(float sigma)
{
  return 1.0f / (2.0f * sigma * sigma + 1e-12f);
}

HV_FUNCTION float waveletWeight(const Surface& centre, const Surface& tap, float centreLuminance,
  float tapLuminance, float luminanceScale, const EdgeStopping& e)
{
  return waveletWeightOfChannels(centre.depth, centre.depthSpread, centre.gradientMagnitude,
    centre.normal, centre.albedo, centreLuminance, luminanceScale, tap.depth, tap.depthSpread,
    tap.gradientMagnitude, tap.normal, tap.albedo, tapLuminance,
    inverseTwoSigmaSquared(e.albedoSigma), e);
}

// Neighbourhood clamping of the reprojected history (Karis 2014; Salvi's variance box): the
// history is limited to mean +- width * standard deviation of the current neighbourhood,
// which removes ghosts that reprojection and T do not catch. A width <= 0 leaves the history
// as it is. That case widens the box by FLT_MAX instead of branching, so that a loop over a
// row of pixels with one width for all vectorises (GCC 12 does not vectorise a choice between
// two per-pixel values on a flag that holds for the whole loop). When clamping, the offsets
// change nothing: x - (+0) and x + (-0) are x exactly, -0 included (x + (+0) is not).
HV_FUNCTION glm::vec4 clampToNeighbourhood(
  const glm::vec4& history, const glm::vec4& mean, const glm::vec4& standardDeviation, float width)
{
  const bool clamp = width > 0.0f;
  const float boxWidth = clamp ? width : 0.0f;
  const float lowOffset = clamp ? 0.0f : FLT_MAX;
  const float highOffset = clamp ? -0.0f : FLT_MAX;
  return glm::clamp(history, mean - boxWidth * standardDeviation - lowOffset,
    mean + boxWidth * standardDeviation + highOffset);
}
}
}

#endif
