// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// The denoiser's per-pixel functions: reprojection geometry (Eq. 2), D2's lambda, w_v's
// sigmoid, the bilateral weight and the disocclusion test.
#include "DenoiseTestScene.h"
#include "hv/denoise/DenoiseKernels.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

using namespace hv::denoise;

namespace
{
glm::vec2 expectProject(const glm::mat4& view, const glm::mat4& projection, int width, int height,
  const glm::vec3& world, float* depthOut = nullptr)
{
  glm::vec2 pixel(-1.0f);
  float depth = 0.0f;
  EXPECT_TRUE(projectToPixel(projection * view, view, width, height, world, pixel, depth));
  if (depthOut)
  {
    *depthOut = depth;
  }
  return pixel;
}
}

// A known camera motion: translating the camera by +1 along x moves a point 5 units ahead to
// the pixel the pinhole model predicts, and its view depth stays 5.
TEST(DenoiseKernels, ReprojectionFollowsCameraTranslation)
{
  const int width = 200, height = 100;
  const float aspect = 2.0f, fovY = glm::radians(60.0f);
  const glm::mat4 projection = glm::perspective(fovY, aspect, 0.1f, 100.0f);
  const glm::mat4 before = glm::lookAt(glm::vec3(0, 0, 5), glm::vec3(0, 0, 0), glm::vec3(0, 1, 0));
  const glm::mat4 after = glm::lookAt(glm::vec3(1, 0, 5), glm::vec3(1, 0, 0), glm::vec3(0, 1, 0));
  const glm::vec3 point(0.0f, 0.0f, 0.0f);
  float depth;
  const glm::vec2 p0 = expectProject(before, projection, width, height, point, &depth);
  EXPECT_NEAR(p0.x, 100.0f, 1e-3f);
  EXPECT_NEAR(p0.y, 50.0f, 1e-3f);
  EXPECT_NEAR(depth, 5.0f, 1e-4f);
  const glm::vec2 p1 = expectProject(after, projection, width, height, point, &depth);
  const float ndcX = (-1.0f / 5.0f) / (std::tan(0.5f * fovY) * aspect);
  EXPECT_NEAR(p1.x, 0.5f * (ndcX + 1.0f) * width, 1e-3f);
  EXPECT_NEAR(p1.y, 50.0f, 1e-3f);
  EXPECT_NEAR(depth, 5.0f, 1e-4f);

  // Behind the camera or off-screen: no pixel.
  glm::vec2 pixel;
  EXPECT_FALSE(projectToPixel(projection * before, before, width, height, glm::vec3(0, 0, 6), pixel, depth));
  EXPECT_FALSE(projectToPixel(projection * before, before, width, height, glm::vec3(20, 0, 0), pixel, depth));
}

// pointOnPixelRay inverts projectToPixel: the point at a given view depth on a pixel-centre ray
// projects back to that pixel's centre at that depth.
TEST(DenoiseKernels, PointOnPixelRayInvertsProjection)
{
  const int width = 200, height = 100;
  const glm::mat4 projection = glm::perspective(glm::radians(60.0f), 2.0f, 0.1f, 100.0f);
  const glm::mat4 view = glm::lookAt(glm::vec3(1, 2, 5), glm::vec3(0, 0, 0), glm::vec3(0, 1, 0));
  const glm::mat4 inverse = glm::inverse(projection * view);
  for (const glm::ivec2 pixel : { glm::ivec2(0, 0), glm::ivec2(37, 81), glm::ivec2(199, 99) })
  {
    for (float viewDepth : { 0.5f, 4.0f, 30.0f })
    {
      glm::vec3 point;
      ASSERT_TRUE(
        pointOnPixelRay(inverse, view, pixel.x, pixel.y, width, height, viewDepth, point));
      float depth;
      const glm::vec2 back = expectProject(view, projection, width, height, point, &depth);
      EXPECT_NEAR(back.x, pixel.x + 0.5f, 2e-3f);
      EXPECT_NEAR(back.y, pixel.y + 0.5f, 2e-3f);
      EXPECT_NEAR(depth, viewDepth, 1e-4f * viewDepth);
    }
  }
}

// Left <-> right: with parallel eyes and off-axis frusta converging at distance D, a point on
// the focal plane has zero disparity, and a point at depth z has the disparity
// 0.5 W ipd (1/z - 1/D) / (tan(theta) aspect). Eq. 2's chain L(t) -> R(t) through the first
// scatter point lands on the same pixel as projecting the point into R directly.
TEST(DenoiseKernels, StereoReprojectionDisparity)
{
  hvtest::SceneState scene;
  const int width = 240, height = 160;
  const float aspect = static_cast<float>(width) / height;
  glm::mat4 leftView, leftProjection, rightView, rightProjection;
  hvtest::eyeMatrices(scene, 0, aspect, leftView, leftProjection);
  hvtest::eyeMatrices(scene, 1, aspect, rightView, rightProjection);
  const float tanHalf = std::tan(glm::radians(20.0f));
  for (float z : { 0.0f, 1.5f, 4.0f })
  {
    const glm::vec3 point(0.2f, -0.3f, z);
    float leftDepth, rightDepth;
    const glm::vec2 left = expectProject(leftView, leftProjection, width, height, point, &leftDepth);
    const glm::vec2 right =
      expectProject(rightView, rightProjection, width, height, point, &rightDepth);
    const float distance = scene.cameraPosition.z - z;
    EXPECT_NEAR(leftDepth, distance, 1e-4f);
    EXPECT_NEAR(rightDepth, distance, 1e-4f);
    const float expected = 0.5f * width * scene.interpupillaryDistance *
      (1.0f / distance - 1.0f / scene.focalDistance) / (tanHalf * aspect);
    EXPECT_NEAR(left.x - right.x, expected, 2e-3f) << "z = " << z;
    EXPECT_NEAR(left.y, right.y, 1e-3f);
  }
  // The focal plane (z = 0 here) has zero parallax.
  const glm::vec2 a = expectProject(leftView, leftProjection, width, height, glm::vec3(0.5f, 0.1f, 0.0f));
  const glm::vec2 b = expectProject(rightView, rightProjection, width, height, glm::vec3(0.5f, 0.1f, 0.0f));
  EXPECT_NEAR(a.x, b.x, 1e-3f);

  // Through the rendered buffers: the first scatter point stored at a left pixel projects into
  // the right eye onto the pixel whose own first scatter point is the same surface point.
  hvtest::EyeBuffers left, right;
  hvtest::renderEye(scene, 0, width, height, 1, left);
  hvtest::renderEye(scene, 1, width, height, 1, right);
  int checked = 0;
  for (int y = 10; y < height; y += 23)
  {
    for (int x = 10; x < width; x += 29)
    {
      const std::size_t i = static_cast<std::size_t>(y) * width + x;
      if (!left.valid[i])
      {
        continue;
      }
      const glm::vec3 x0(left.position[3 * i], left.position[3 * i + 1], left.position[3 * i + 2]);
      glm::vec2 pixel;
      float depth;
      if (!projectToPixel(rightProjection * rightView, rightView, width, height, x0, pixel, depth))
      {
        continue;
      }
      const std::size_t q = static_cast<std::size_t>(pixel.y) * width + static_cast<std::size_t>(pixel.x);
      if (!right.valid[q])
      {
        continue;
      }
      const glm::vec3 x1(right.position[3 * q], right.position[3 * q + 1], right.position[3 * q + 2]);
      // Same surface: within a pixel footprint (about 0.03 world units at this distance).
      if (std::abs(right.depth[q] - depth) < 0.01f * depth)
      {
        EXPECT_LT(glm::length(x1 - x0), 0.08f);
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 20);
}

// D2's lambda = alpha (beta - exp(-|gamma_L - gamma_R|)): 0.5 for equal albedo, growing with
// the difference towards 1, never outside [0, 1].
TEST(DenoiseKernels, StereoBlendWeight)
{
  const glm::vec3 albedo(0.4f, 0.5f, 0.6f);
  EXPECT_NEAR(stereoBlendWeight(albedo, albedo, 0.5f, 2.0f), 0.5f, 1e-6f);
  float previous = 0.5f;
  for (float d : { 0.05f, 0.2f, 0.5f, 1.0f, 3.0f, 10.0f, 30.0f })
  {
    const float lambda = stereoBlendWeight(albedo, albedo + glm::vec3(d, 0.0f, 0.0f), 0.5f, 2.0f);
    EXPECT_GT(lambda, previous) << d;
    previous = lambda;
  }
  EXPECT_GT(previous, 0.9999f);
  EXPECT_NEAR(stereoBlendWeight(glm::vec3(0.0f), glm::vec3(1.0f), 0.5f, 2.0f),
    0.5f * (2.0f - std::exp(-std::sqrt(3.0f))), 1e-6f);
  // Other alpha, beta are clamped rather than extrapolated.
  EXPECT_EQ(stereoBlendWeight(albedo, albedo + glm::vec3(5.0f), 1.0f, 2.0f), 1.0f);
  EXPECT_EQ(stereoBlendWeight(albedo, albedo, 0.5f, 0.5f), 0.0f);
}

// D2's noise test: 1 without a difference or with the test off, e^-1/2 at k standard
// deviations, falling with the difference, and finite for a zero variance.
TEST(DenoiseKernels, StereoAgreement)
{
  EXPECT_EQ(stereoAgreement(5.0f, 1.0f, 0.0f), 1.0f); // off: the paper's lambda alone
  EXPECT_EQ(stereoAgreementTerm(0.2f, 0.04f, 3.0f), stereoAgreement(0.2f, 0.04f, 3.0f));
  EXPECT_NEAR(stereoAgreement(0.0f, 0.04f, 3.0f), 1.0f, 1e-6f);
  const float sigma = 0.2f; // of the difference, sqrt(v)
  EXPECT_NEAR(stereoAgreement(3.0f * sigma, sigma * sigma, 3.0f), std::exp(-0.5f), 1e-5f);
  EXPECT_NEAR(stereoAgreement(-3.0f * sigma, sigma * sigma, 3.0f), std::exp(-0.5f), 1e-5f);
  float previous = 1.0f;
  for (float d : { 0.1f, 0.3f, 0.6f, 1.0f, 3.0f })
  {
    const float agreement = stereoAgreement(d, sigma * sigma, 3.0f);
    EXPECT_LT(agreement, previous) << d;
    previous = agreement;
  }
  EXPECT_LT(previous, 1e-4f);
  // No noise: any difference is real, none is no reason to stop blending.
  EXPECT_LT(stereoAgreement(0.1f, 0.0f, 3.0f), 1e-30f);
  EXPECT_NEAR(stereoAgreement(0.0f, 0.0f, 3.0f), 1.0f, 1e-6f);
}

// w_v's sigmoid delta(1 / (T - 1)) falls with T; T = 0 and T -> 1 are finite, NaN drops the
// history, and the plain logistic gives the textbook value at T = 0.
TEST(DenoiseKernels, TemporalWeightDecreasesWithIlluminationDifference)
{
  float previous = 2.0f;
  for (int i = 0; i <= 1000; ++i)
  {
    const float t = static_cast<float>(i) / 1000.0f;
    const float gate = temporalGate(t, 20.0f, -1.25f);
    EXPECT_TRUE(std::isfinite(gate));
    EXPECT_GE(gate, 0.0f);
    EXPECT_LE(gate, 1.0f);
    EXPECT_LE(gate, previous) << "T = " << t;
    previous = gate;
  }
  EXPECT_GT(temporalGate(0.0f, 20.0f, -1.25f), 0.99f);
  EXPECT_GT(temporalGate(0.014f, 20.0f, -1.25f), 0.95f); // sensor noise (issue 3's measurement)
  EXPECT_LT(temporalGate(0.65f, 20.0f, -1.25f), 1e-3f);  // a lamp switched on
  EXPECT_EQ(temporalGate(1.0f, 20.0f, -1.25f), 0.0f);
  EXPECT_EQ(temporalGate(0.9999999f, 20.0f, -1.25f), 0.0f);
  EXPECT_EQ(temporalGate(std::numeric_limits<float>::quiet_NaN(), 20.0f, -1.25f), 0.0f);
  EXPECT_EQ(temporalGate(-0.5f, 20.0f, -1.25f), temporalGate(0.0f, 20.0f, -1.25f));
  EXPECT_NEAR(temporalGate(0.0f, 1.0f, 0.0f), 1.0f / (1.0f + std::exp(1.0f)), 1e-6f);
  EXPECT_LT(temporalGate(0.5f, 1.0f, 0.0f), temporalGate(0.0f, 1.0f, 0.0f));
}

// The history's arc narrows where the view grazes a surface: whole for a view along the
// normal and above the cosine, in proportion to the cosine below it, never below the
// fraction; whole where the gradient defines no surface, or with the test turned off.
TEST(DenoiseKernels, GrazingViewNarrowsTheHistoryArc)
{
  const float inverseCosine = 1.0f / 0.5f;
  EXPECT_EQ(grazingHistoryArc(1.0f, 1.0f, 0.15f, inverseCosine, 0.5f), 1.0f);
  EXPECT_EQ(grazingHistoryArc(0.6f, 1.0f, 0.15f, inverseCosine, 0.5f), 1.0f);
  EXPECT_NEAR(grazingHistoryArc(0.4f, 1.0f, 0.15f, inverseCosine, 0.5f), 0.8f, 1e-6f);
  EXPECT_NEAR(grazingHistoryArc(0.3f, 1.0f, 0.15f, inverseCosine, 0.2f), 0.6f, 1e-6f);
  EXPECT_EQ(grazingHistoryArc(0.1f, 1.0f, 0.15f, inverseCosine, 0.5f), 0.5f);
  EXPECT_EQ(grazingHistoryArc(0.0f, 1.0f, 0.15f, inverseCosine, 0.5f), 0.5f);
  // The normal's sign (the gradient points into or out of the tissue) does not matter.
  EXPECT_EQ(grazingHistoryArc(-0.4f, 1.0f, 0.15f, inverseCosine, 0.5f),
    grazingHistoryArc(0.4f, 1.0f, 0.15f, inverseCosine, 0.5f));
  float previous = 0.0f;
  for (int i = 0; i <= 100; ++i)
  {
    const float arc = grazingHistoryArc(i / 100.0f, 1.0f, 0.15f, inverseCosine, 0.25f);
    EXPECT_GE(arc, previous) << "cos " << i / 100.0f;
    previous = arc;
  }
  // Weak gradients (volume scattering, random normals) and the test turned off.
  EXPECT_EQ(grazingHistoryArc(0.0f, 0.1f, 0.15f, inverseCosine, 0.5f), 1.0f);
  EXPECT_EQ(
    grazingHistoryArc(0.0f, 1.0f, std::numeric_limits<float>::infinity(), 1.0f, 0.5f), 1.0f);
}

TEST(DenoiseKernels, BilateralWeightAndDisocclusion)
{
  EdgeStopping edges;
  Surface a;
  a.kind = SurfaceOwn;
  a.depth = 5.0f;
  a.normal = glm::vec3(0, 0, 1);
  a.gradientMagnitude = 1.0f;
  a.albedo = glm::vec3(0.5f);
  EXPECT_NEAR(bilateralWeight(a, a, edges), 1.0f, 1e-6f);
  Surface farther = a;
  farther.depth = 5.5f;
  EXPECT_NEAR(bilateralWeight(a, farther, edges), std::exp(-0.5f / (0.02f * 5.0f)), 1e-6f);
  Surface turned = a;
  turned.normal = glm::vec3(0, 1, 0);
  EXPECT_NEAR(bilateralWeight(a, turned, edges), std::exp(-edges.normalSharpness), 1e-6f);
  // Inside homogeneous material the gradient direction is noise: no normal penalty.
  turned.gradientMagnitude = 0.0f;
  EXPECT_NEAR(bilateralWeight(a, turned, edges), 1.0f, 1e-6f);
  Surface tinted = a;
  tinted.albedo = glm::vec3(0.5f, 0.7f, 0.5f);
  EXPECT_NEAR(bilateralWeight(a, tinted, edges), std::exp(-0.04f / 0.02f), 1e-5f);

  // Disocclusion: an occluder 10 % nearer, a background pixel, or a turned surface.
  EXPECT_TRUE(consistentSurface(a, 5.05f, a.normal, 1.0f, 0.0f, 0.03f, 0.5f, 0.1f));
  EXPECT_FALSE(consistentSurface(a, 5.5f, a.normal, 1.0f, 0.0f, 0.03f, 0.5f, 0.1f));
  Surface none;
  EXPECT_FALSE(consistentSurface(none, 5.0f, a.normal, 1.0f, 0.0f, 0.03f, 0.5f, 0.1f));
  EXPECT_FALSE(consistentSurface(a, 5.0f, glm::vec3(0, 1, 0), 1.0f, 0.0f, 0.03f, 0.5f, 0.1f));
  EXPECT_TRUE(consistentSurface(a, 5.0f, glm::vec3(0, 1, 0), 0.0f, 0.0f, 0.03f, 0.5f, 0.1f));
  // Inside translucent material (no gradient) the first scatter depth is random: a depth
  // spread of 0.3 on both sides accepts the 0.5 difference, a spread on one side only does not.
  Surface translucent = a;
  translucent.depthSpread = 0.3f;
  translucent.gradientMagnitude = 0.0f;
  EXPECT_TRUE(consistentSurface(translucent, 5.5f, a.normal, 0.0f, 0.3f, 0.03f, 0.5f, 0.1f));
  EXPECT_FALSE(consistentSurface(translucent, 5.5f, a.normal, 0.0f, 0.0f, 0.03f, 0.5f, 0.1f));
  // On a surface (strong gradient) the spread is geometry, a silhouette: no slack.
  EXPECT_FALSE(consistentSurface(translucent, 5.5f, a.normal, 1.0f, 0.3f, 0.03f, 0.5f, 0.1f));
  // ... unless the stored pixel's history has seen its depth move that much by chance.
  Surface jittering = a;
  jittering.depthJitter = 0.4f;
  EXPECT_TRUE(consistentSurface(jittering, 5.5f, a.normal, 1.0f, 0.0f, 0.03f, 0.5f, 0.1f));
  EXPECT_FALSE(consistentSurface(jittering, 5.6f, a.normal, 1.0f, 0.0f, 0.03f, 0.5f, 0.1f));
  // Normals 72 degrees apart: a disocclusion where both gradients exceed normalGradient and
  // the stored normal has been steady, not where it has wandered that far or the gradients
  // are weak (mostly volume scattering).
  const glm::vec3 tilted(std::sin(std::acos(0.3f)), 0.0f, 0.3f);
  Surface weak = a;
  weak.gradientMagnitude = 0.2f;
  EXPECT_FALSE(consistentSurface(weak, 5.0f, tilted, 0.2f, 0.0f, 0.03f, 0.5f, 0.1f));
  EXPECT_TRUE(consistentSurface(weak, 5.0f, tilted, 0.2f, 0.0f, 0.03f, 0.5f, 0.3f));
  EXPECT_FALSE(consistentSurface(a, 5.0f, tilted, 1.0f, 0.0f, 0.03f, 0.5f, 0.3f));
  Surface wandering = a;
  wandering.normalJitter = 0.8f;
  EXPECT_TRUE(consistentSurface(wandering, 5.0f, tilted, 1.0f, 0.0f, 0.03f, 0.5f, 0.3f));
  EXPECT_FALSE(consistentSurface(wandering, 5.0f, -a.normal, 1.0f, 0.0f, 0.03f, 0.5f, 0.3f));
}

// The normal term counts the weaker gradient magnitude above the floor only: normals 90
// degrees apart cost nothing where a gradient is at or below it (inside translucent tissue),
// and k (g - floor) where it is above (a surface). Floor 0 is the whole gradient.
TEST(DenoiseKernels, NormalTermCountsTheGradientAboveTheFloor)
{
  EXPECT_EQ(normalGradient(0.2f, 0.8f, 0.0f), 0.2f);
  EXPECT_EQ(normalGradient(0.2f, 0.8f, 0.3f), 0.0f);
  EXPECT_EQ(normalGradient(0.3f, 0.3f, 0.3f), 0.0f);
  EXPECT_NEAR(normalGradient(0.8f, 0.9f, 0.3f), 0.5f, 1e-6f);
  EXPECT_EQ(normalGradient(0.0f, 0.0f, 0.0f), 0.0f);

  EdgeStopping edges{ 0.2f, 32.0f, 0.01f, 0.3f };
  const glm::vec3 up(0.0f, 0.0f, 1.0f), side(0.0f, 1.0f, 0.0f), albedo(0.5f);
  auto weight = [&](float gradient, const glm::vec3& tapNormal)
  {
    return waveletWeightOfChannels(5.0f, 0.0f, gradient, up, albedo, 1.0f, 1.0f, 5.0f, 0.0f,
      gradient, tapNormal, albedo, 1.0f, inverseTwoSigmaSquared(edges.albedoSigma), edges);
  };
  EXPECT_EQ(weight(0.25f, side), weight(0.25f, up));
  EXPECT_NEAR(weight(0.8f, side) / weight(0.8f, up), std::exp(-32.0f * 0.5f), 1e-9f);
  Surface a;
  a.kind = SurfaceOwn;
  a.depth = 5.0f;
  a.normal = up;
  a.gradientMagnitude = 0.25f;
  a.albedo = albedo;
  Surface turned = a;
  turned.normal = side;
  EXPECT_NEAR(bilateralWeight(a, turned, edges), 1.0f, 1e-6f);
  edges.normalGradientFloor = 0.0f;
  EXPECT_NEAR(bilateralWeight(a, turned, edges), std::exp(-32.0f * 0.25f), 1e-6f);
}

// The wavelet filter's albedo term scaled by 1 - w + w max(g, g'): exactly 1 for w = 0 and
// exactly the larger gradient for w = 1, and the weight follows.
TEST(DenoiseKernels, AlbedoTermScalesWithTheLargerGradient)
{
  EXPECT_EQ(albedoGradientScale(0.2f, 0.7f, 0.0f), 1.0f);
  EXPECT_EQ(albedoGradientScale(0.2f, 0.7f, 1.0f), 0.7f);
  EXPECT_EQ(albedoGradientScale(0.7f, 0.2f, 1.0f), 0.7f);
  EXPECT_EQ(albedoGradientScale(0.0f, 0.0f, 1.0f), 0.0f);
  EXPECT_NEAR(albedoGradientScale(0.1f, 0.3f, 0.5f), 0.65f, 1e-6f);

  EdgeStopping edges{ 0.2f, 32.0f, 0.01f, 0.15f, 1.0f };
  const glm::vec3 up(0.0f, 0.0f, 1.0f), grey(0.5f), lighter(0.7f);
  auto weight = [&](float centreGradient, float tapGradient)
  {
    return waveletWeightOfChannels(5.0f, 0.0f, centreGradient, up, grey, 1.0f, 1.0f, 5.0f, 0.0f,
      tapGradient, up, lighter, 1.0f, inverseTwoSigmaSquared(edges.albedoSigma), edges);
  };
  // |d albedo|^2 / (2 sigma^2) = 3 (0.2)^2 / 0.08 = 1.5, times the larger gradient.
  EXPECT_NEAR(weight(0.1f, 0.2f), std::exp(-1.5f * 0.2f), 1e-5f);
  EXPECT_NEAR(weight(0.9f, 0.2f), std::exp(-1.5f * 0.9f), 1e-5f);
  edges.albedoGradientWeight = 0.0f;
  EXPECT_NEAR(weight(0.1f, 0.2f), std::exp(-1.5f), 1e-5f);
}

// Re-modulation's albedo: the history's mean up to the low gradient, exactly the frame's from
// the high one on, linear between; a step at the high gradient when the range is empty.
TEST(DenoiseKernels, RemodulationAlbedoFollowsTheGradient)
{
  const glm::vec3 frame(0.8f, 0.4f, 0.2f), history(0.4f, 0.6f, 0.2f);
  const glm::vec2 gradients(0.15f, 0.3f);
  EXPECT_EQ(historyRemodulationAlbedo(frame, history, 0.0f, gradients), history);
  EXPECT_EQ(historyRemodulationAlbedo(frame, history, 0.15f, gradients), history);
  EXPECT_EQ(historyRemodulationAlbedo(frame, history, 0.3f, gradients), frame);
  EXPECT_EQ(historyRemodulationAlbedo(frame, history, 1.0f, gradients), frame);
  const glm::vec3 halfway = historyRemodulationAlbedo(frame, history, 0.225f, gradients);
  EXPECT_NEAR(halfway.x, 0.6f, 1e-6f);
  EXPECT_NEAR(halfway.y, 0.5f, 1e-6f);
  EXPECT_NEAR(halfway.z, 0.2f, 1e-6f);
  const glm::vec2 step(0.5f, 0.5f);
  EXPECT_EQ(historyRemodulationAlbedo(frame, history, 0.49f, step), history);
  EXPECT_EQ(historyRemodulationAlbedo(frame, history, 0.5f, step), frame);
}

TEST(DenoiseKernels, DemodulationRoundTripAndClamp)
{
  const glm::vec4 radiance(0.3f, 0.2f, 0.0f, 0.8f);
  const glm::vec3 albedo(0.6f, 0.4f, 0.0f);
  const glm::vec4 signal = demodulate(radiance, albedo);
  EXPECT_NEAR(signal.x, 0.5f, 1e-6f);
  EXPECT_NEAR(signal.y, 0.5f, 1e-6f);
  EXPECT_EQ(signal.z, 0.0f); // no albedo: kept as is
  EXPECT_EQ(signal.w, 0.8f); // coverage is not an albedo-weighted quantity
  const glm::vec4 back = remodulate(signal, albedo);
  for (int c = 0; c < 4; ++c)
  {
    EXPECT_NEAR(back[c], radiance[c], 1e-6f);
  }
  const glm::vec4 clamped =
    clampToNeighbourhood(glm::vec4(5.0f, 0.0f, 1.0f, 1.0f), glm::vec4(1.0f), glm::vec4(0.5f), 2.0f);
  EXPECT_EQ(clamped, glm::vec4(2.0f, 0.0f, 1.0f, 1.0f));
  // Width 0: no clamping.
  EXPECT_EQ(clampToNeighbourhood(
              glm::vec4(5.0f, 0.0f, -0.0f, 1.0f), glm::vec4(1.0f), glm::vec4(0.5f), 0.0f),
    glm::vec4(5.0f, 0.0f, -0.0f, 1.0f));
}

// Catmull-Rom weights: a partition of unity that interpolates the taps and reproduces a ramp,
// so a fetch between pixel centres neither blurs nor shifts a linear gradient.
TEST(DenoiseKernels, CatmullRomWeights)
{
  float w[4];
  catmullRomWeights(0.0f, w);
  EXPECT_EQ(w[0], 0.0f);
  EXPECT_EQ(w[1], 1.0f);
  EXPECT_EQ(w[2], 0.0f);
  EXPECT_EQ(w[3], 0.0f);
  for (float t : { 0.1f, 0.25f, 0.5f, 0.8f, 0.999f })
  {
    catmullRomWeights(t, w);
    EXPECT_NEAR(w[0] + w[1] + w[2] + w[3], 1.0f, 1e-6f);
    // Taps at -1, 0, 1, 2 of the ramp f(x) = 3 x + 1.
    EXPECT_NEAR(w[0] * -2.0f + w[1] * 1.0f + w[2] * 4.0f + w[3] * 7.0f, 3.0f * t + 1.0f, 1e-5f);
    EXPECT_LT(w[0], 0.0f); // the negative lobes that keep the detail
    EXPECT_LT(w[3], 0.0f);
  }
  catmullRomWeights(0.5f, w);
  EXPECT_NEAR(w[1], 0.5625f, 1e-6f); // symmetric at the midpoint: 9/16 and -1/16
  EXPECT_NEAR(w[0], -0.0625f, 1e-6f);
  EXPECT_EQ(w[1], w[2]);
}

// The wavelet filter's inline e^-x (a vectorisable series) against the double-precision
// exponential, and the edge-stopping weight's cut-off at e^-30.
TEST(DenoiseKernels, InlineExponentialMatchesLibm)
{
  double worst = 0.0;
  for (int k = 0; k <= 86000; ++k)
  {
    const float x = 0.001f * static_cast<float>(k);
    const double expected = std::exp(-static_cast<double>(x));
    worst = std::max(worst, std::abs(exponentialOfNegative(x) - expected) / expected);
  }
  std::cout << "largest relative error of e^-x on [0, 86]: " << worst << "\n";
  EXPECT_LT(worst, 5e-6);
  EXPECT_EQ(exponentialOfNegative(-2.0f), 1.0f);
  EXPECT_EQ(exponentialOfNegative(-0.0f), 1.0f);
  EXPECT_GT(exponentialOfNegative(1000.0f), 0.0f); // clamped, not NaN or infinite
  EXPECT_EQ(
    exponentialOfNegative(std::numeric_limits<float>::infinity()), exponentialOfNegative(1000.0f));

  // The clamps compare bit patterns as integers; as float comparisons they give every result
  // bit for bit the same, from -100 to 100 in steps of 2^-12 (those values' products with
  // log2(e) cover every rounding case of the clamps and of 2^-t's nearest integer) and at the
  // extremes.
  const auto withFloatClamps = [](float x)
  { return twoToTheNegative(glm::min(glm::max(x, 0.0f) * 1.44269504f, 125.0f)); };
  const auto bits = [](float v)
  {
    std::uint32_t b;
    std::memcpy(&b, &v, sizeof(b));
    return b;
  };
  int differing = 0;
  for (int k = -409600; k <= 409600; ++k)
  {
    const float x = static_cast<float>(k) / 4096.0f;
    differing += bits(exponentialOfNegative(x)) != bits(withFloatClamps(x)) ? 1 : 0;
  }
  for (const float x : { -std::numeric_limits<float>::max(), -0.0f, 0.0f,
         std::numeric_limits<float>::denorm_min(), 86.0f, 86.64f, 86.7f, 1e30f,
         std::numeric_limits<float>::max(), std::numeric_limits<float>::infinity() })
  {
    differing += bits(exponentialOfNegative(x)) != bits(withFloatClamps(x)) ? 1 : 0;
  }
  EXPECT_EQ(differing, 0);

  Surface centre;
  centre.kind = SurfaceOwn;
  centre.depth = 2.0f;
  centre.normal = glm::vec3(0.0f, 0.0f, 1.0f);
  centre.albedo = glm::vec3(0.5f);
  const EdgeStopping edges;
  EXPECT_NEAR(waveletWeight(centre, centre, 1.0f, 1.0f, 1.0f, edges), 1.0f, 1e-6f);
  EXPECT_NEAR(waveletWeight(centre, centre, 1.0f, 1.0f + 29.0f, 1.0f, edges), std::exp(-29.0f),
    5e-6f * std::exp(-29.0f));
  EXPECT_EQ(waveletWeight(centre, centre, 1.0f, 1.0f + 31.0f, 1.0f, edges), 0.0f);
}

// D2's blend of coverage and colour apart: the premultiplied blend where the coverages are
// equal, each eye's own coverage with the mean colour at a silhouette, and no colour estimated
// below ColourCoverageFloor.
TEST(DenoiseKernels, StereoBlendUnpremultiplied)
{
  const glm::vec3 colour(0.8f, 0.4f, 0.2f), otherColour(0.6f, 0.5f, 0.1f);
  // Equal coverages: the premultiplied blend, whatever the colour weight equal to the
  // coverage weight.
  const glm::vec4 own(0.7f * colour, 0.7f), other(0.7f * otherColour, 0.7f);
  const glm::vec4 equal = stereoBlendUnpremultiplied(own, other, 0.4f, 0.4f);
  const glm::vec4 premultiplied = 0.6f * own + 0.4f * other;
  for (int c = 0; c < 4; ++c)
  {
    EXPECT_NEAR(equal[c], premultiplied[c], 1e-6f);
  }
  // A silhouette seen from two sides: this eye 30 % covered, the other fully. With the
  // coverage kept (weight 0) and the colours averaged, the pixel keeps its coverage and takes
  // the mean colour.
  const glm::vec4 edge(0.3f * colour, 0.3f), seenFully(otherColour, 1.0f);
  const glm::vec4 kept = stereoBlendUnpremultiplied(edge, seenFully, 0.5f, 0.0f);
  const glm::vec3 meanColour = 0.5f * (colour + otherColour);
  EXPECT_FLOAT_EQ(kept.w, 0.3f);
  for (int c = 0; c < 3; ++c)
  {
    EXPECT_NEAR(kept[c], 0.3f * meanColour[c], 1e-6f);
  }
  // Both weights 0: the own value, unchanged; both 1: the other's.
  const glm::vec4 ownKept = stereoBlendUnpremultiplied(edge, seenFully, 0.0f, 0.0f);
  const glm::vec4 otherTaken = stereoBlendUnpremultiplied(edge, seenFully, 1.0f, 1.0f);
  for (int c = 0; c < 4; ++c)
  {
    EXPECT_NEAR(ownKept[c], edge[c], 1e-6f);
    EXPECT_NEAR(otherTaken[c], seenFully[c], 1e-6f);
  }
  // Below the floor a colour is not estimated (its noise divided by a tiny coverage): the
  // premultiplied values are blended with the coverage weight, and no value is infinite.
  const glm::vec4 empty(0.0f, 0.0f, 0.0f, 0.0f);
  const glm::vec4 fromEmpty = stereoBlendUnpremultiplied(empty, seenFully, 0.5f, 0.25f);
  const glm::vec4 expected = 0.25f * seenFully;
  for (int c = 0; c < 4; ++c)
  {
    EXPECT_FLOAT_EQ(fromEmpty[c], expected[c]);
  }
  const glm::vec4 grazing(0.005f * colour, 0.005f);
  const glm::vec4 fromGrazing = stereoBlendUnpremultiplied(seenFully, grazing, 0.5f, 0.5f);
  for (int c = 0; c < 4; ++c)
  {
    EXPECT_NEAR(fromGrazing[c], 0.5f * (seenFully[c] + grazing[c]), 1e-6f);
  }
}

// The coverage edge-stopping: off at width 0; a translucent neighbour whose coverage differs by
// one standard deviation weighs e^(-1/(2k^2)), a silhouette's step of 1/2 (6.5 standard
// deviations of a coverage of 3/4 over 32 frames) under 1 %; coverage at 0 or 1 has no noise
// to forgive.
TEST(DenoiseKernels, CoverageSharpness)
{
  EXPECT_EQ(coverageSharpness(0.5f, 32.0f, 0.0f), 0.0f);
  const float frames = 32.0f, width = 2.0f;
  const float deviation = std::sqrt(0.75f * 0.25f / frames);
  const float sharpness = coverageSharpness(0.75f, frames, width);
  EXPECT_NEAR(std::exp(-deviation * deviation * sharpness), std::exp(-1.0f / 8.0f), 1e-5f);
  EXPECT_LT(std::exp(-0.5f * 0.5f * sharpness), 0.01f);
  EXPECT_GT(coverageSharpness(1.0f, frames, width), 1e10f);
  EXPECT_GT(coverageSharpness(1.5f, frames, width), 1e10f); // clamped to [0, 1]
  // More frames, a less noisy coverage, a sharper term.
  EXPECT_GT(coverageSharpness(0.75f, 64.0f, width), sharpness);
}

TEST(DenoiseKernels, CrossViewCoverage)
{
  // Off, or coverages that agree: the other eye's samples count fully.
  EXPECT_EQ(crossViewCoverage(1.0f, 32.0f, 0.4f, 32.0f, 0.0f), 1.0f);
  EXPECT_FLOAT_EQ(crossViewCoverage(0.6f, 16.0f, 0.6f, 8.0f, 1.0f), 1.0f);
  EXPECT_FLOAT_EQ(crossViewCoverage(1.0f, 32.0f, 1.0f, 32.0f, 1.0f), 1.0f); // opaque in both
  // Histories of 32 and 16 frames whose coverages differ by d: e^(-d^2 / (2 k^2 v)), v the sum
  // of their Bernoulli variances.
  const float a = 0.7f, b = 0.6f;
  const float variance = a * (1.0f - a) / 32.0f + b * (1.0f - b) / 16.0f;
  EXPECT_NEAR(crossViewCoverage(a, 32.0f, b, 16.0f, 2.0f),
    std::exp(-(a - b) * (a - b) / (8.0f * variance)), 1e-5f);
  // A silhouette seen from two sides (full coverage in one eye, half in the other, over long
  // histories) stops the other eye's samples; short histories make the same step less certain.
  EXPECT_LT(crossViewCoverage(1.0f, 32.0f, 0.5f, 32.0f, 1.0f), 1e-6f);
  EXPECT_GT(crossViewCoverage(1.0f, 1.0f, 0.5f, 1.0f, 1.0f),
    crossViewCoverage(1.0f, 32.0f, 0.5f, 32.0f, 1.0f));
  // Symmetric in the eyes.
  EXPECT_FLOAT_EQ(crossViewCoverage(0.9f, 8.0f, 0.5f, 4.0f, 1.0f),
    crossViewCoverage(0.5f, 4.0f, 0.9f, 8.0f, 1.0f));
  // The term alone, as the vectorised cross-view loop evaluates it everywhere: equal coverages
  // give exactly 1, with or without a width, which is what that loop puts where the coverages
  // are not compared.
  EXPECT_EQ(crossViewCoverageTerm(0.0f, 1.0f, 0.0f, 1.0f, 1.0f), 1.0f);
  EXPECT_EQ(crossViewCoverageTerm(0.0f, 1.0f, 0.0f, 1.0f, 0.0f), 1.0f);
  EXPECT_EQ(crossViewCoverageTerm(0.7f, 32.0f, 0.6f, 16.0f, 2.0f),
    crossViewCoverage(0.7f, 32.0f, 0.6f, 16.0f, 2.0f));
}
