// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Classification (VolumeGrid), ray set-up (makeIndexRay), the majorant grid and the two
// tracking estimators of Tracking.h: ratio tracking (estimateTransmittance) and delta tracking
// (sampleFreeFlight), against Beer-Lambert.
//
// Transmittance assertions are two-fold: the estimate lies within 5 standard errors of the
// exact value (no bias detectable at this sample count) AND within the 1 % of the acceptance
// criterion ("a homogeneous slab of known sigmaT transmits exp(-sigmaT d) of a directional
// light within 1 %"). Sample counts are chosen so that 5 standard errors are below 1 % of the
// exact value, which the tests check too, so the 1 % bound is never a matter of luck.
#include "KernelTestUtilities.h"

#include "hv/Render.h"
#include "hv/Tracking.h"
#include "hv/VolumeGrid.h"

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace
{
using hvtest::RunningStats;

const glm::ivec3 Dims(16, 16, 16);
const glm::vec3 Spacing(0.5f, 0.25f, 0.75f);
const glm::vec3 Origin(-2.0f, 1.0f, 0.5f);
// Extent of the data in world space: [Origin, Origin + (Dims - 1) * Spacing].
const glm::vec3 WorldLow = Origin;
const glm::vec3 WorldHigh = Origin + glm::vec3(Dims - 1) * Spacing;

glm::mat4 indexToWorld()
{
  return glm::scale(glm::translate(glm::mat4(1.0f), Origin), Spacing);
}

// alpha 0.1 per unit distance 1, density scale 0.75: sigmaT = -ln(0.9) * 0.75 = 0.0790.
constexpr float Alpha = 0.1f;
constexpr float UnitDistance = 1.0f;
constexpr float DensityScale = 0.75f;

void makeHomogeneous(hv::VolumeGrid& grid, int cellSize = 4)
{
  grid.setCellSize(cellSize);
  grid.setIndexToWorld(indexToWorld());
  grid.setScalars(
    Dims, std::vector<float>(static_cast<std::size_t>(Dims.x) * Dims.y * Dims.z, 1.0f));
  hvtest::setConstantTransferFunction(grid, Alpha, glm::vec3(0.5f), UnitDistance, DensityScale);
}

struct TransmittanceEstimates
{
  RunningStats ratio; // ratio tracking
  RunningStats delta; // delta tracking: the fraction of free flights that leave the medium
};

TransmittanceEstimates estimate(const hv::VolumeView& volume, const hv::ClippingPlanes& clipping,
  const glm::vec3& origin, const glm::vec3& direction, float tMax, int samples,
  std::uint32_t stream)
{
  TransmittanceEstimates result;
  hv::IndexRay ray;
  if (!hv::makeIndexRay(volume, clipping, origin, direction, 0.0f, tMax, ray))
  {
    result.ratio.add(1.0);
    result.delta.add(1.0);
    return result;
  }
  hv::Pcg32 rng = hv::makePixelRng(stream, 0u, 0u, 31u);
  for (int i = 0; i < samples; ++i)
  {
    result.ratio.add(hv::estimateTransmittance(volume, ray, rng));
    float t;
    result.delta.add(hv::sampleFreeFlight(volume, ray, rng, t) ? 0.0 : 1.0);
  }
  return result;
}

void expectTransmittance(const std::string& what, const RunningStats& stats, double exact)
{
  const double error = stats.mean() - exact;
  std::printf(
    "[ info ] %-44s T = %.5f, estimate %.5f +- %.5f, relative error %+.3f %% (5 SE = %.3f %%)\n",
    what.c_str(), exact, stats.mean(), stats.standardError(), 100.0 * error / exact,
    500.0 * stats.standardError() / exact);
  EXPECT_LT(5.0 * stats.standardError(), 0.01 * exact)
    << what << ": too few samples for a 1 % test";
  EXPECT_NEAR(stats.mean(), exact, 5.0 * stats.standardError()) << what;
  EXPECT_NEAR(stats.mean(), exact, 0.01 * exact) << what;
}

constexpr int Samples = 500000;
}

TEST(VolumeGrid, ExtinctionFromOpacity)
{
  hv::VolumeGrid grid;
  makeHomogeneous(grid);
  hv::VolumeView v = grid.view();
  const double sigma = hvtest::extinctionOf(Alpha, UnitDistance, DensityScale);
  EXPECT_NEAR(sigma, 0.0790, 1e-4);
  hv::Pcg32 rng = hv::makePixelRng(0u, 0u, 0u, 32u);
  for (int i = 0; i < 1000; ++i)
  {
    const glm::vec3 p =
      glm::vec3(rng.nextFloat(), rng.nextFloat(), rng.nextFloat()) * glm::vec3(Dims - 1);
    ASSERT_NEAR(v.sigmaT(p), sigma, 1e-6 * sigma);
  }

  // A table: each node's extinction is -ln(1 - alpha_i) / unitDistance * densityScale, linear
  // in between; alpha = 1 is capped to a finite extinction.
  const std::vector<float> opacity = { 0.0f, 0.25f, 0.5f, 0.9f, 1.0f };
  std::vector<float> albedo(opacity.size() * 3, 1.0f);
  grid.setTransferFunction(opacity, albedo, 0.5f, 2.0f);
  v = grid.view();
  ASSERT_EQ(v.transfer.size, 5);
  for (int i = 0; i < 4; ++i)
  {
    const double expected = hvtest::extinctionOf(opacity[i], 0.5, 2.0);
    EXPECT_NEAR(v.transfer.sigmaT(i / 4.0f), expected, 1e-5 * (1.0 + expected));
    if (i < 3)
    {
      const double next = hvtest::extinctionOf(opacity[i + 1], 0.5, 2.0);
      EXPECT_NEAR(
        v.transfer.sigmaT((i + 0.5f) / 4.0f), 0.5 * (expected + next), 1e-5 * (1.0 + next));
    }
  }
  // Opacity 1 is capped at 1 - 1e-6 (in float, so -ln(1.0133e-6) rather than -ln(1e-6)).
  EXPECT_TRUE(std::isfinite(v.transfer.sigmaT(1.0f)));
  EXPECT_NEAR(
    v.transfer.sigmaT(1.0f), -std::log(1e-6) / 0.5 * 2.0, 0.002 * -std::log(1e-6) / 0.5 * 2.0);
}

// Trilinear interpolation reproduces any field that is trilinear in the voxel index exactly
// (up to the 16-bit storage), on every path of scalarAt: the vectorised host path for volumes
// at least two voxels wide, the scalar path for one-voxel-wide ones, degenerate axes and
// positions clamped at the faces.
TEST(VolumeGrid, ScalarInterpolationIsTrilinear)
{
  const glm::ivec3 shapes[] = { { 7, 5, 6 }, { 1, 4, 3 }, { 5, 1, 4 }, { 6, 3, 1 }, { 2, 2, 2 } };
  for (const glm::ivec3& dims : shapes)
  {
    // In [0.05, 0.95] on the whole box, so neither storage end clips it.
    const auto field = [&](const glm::vec3& p) {
      const glm::vec3 q = p / glm::max(glm::vec3(dims - 1), glm::vec3(1.0f));
      return 0.05f + 0.3f * q.x + 0.2f * q.y + 0.25f * q.z + 0.1f * q.x * q.y * q.z +
        0.05f * (q.x * q.z - q.y * q.z);
    };
    hv::VolumeGrid grid;
    grid.setScalars(dims, hvtest::sampleField(dims, field));
    const hv::VolumeView v = grid.view();
    hv::Pcg32 rng = hv::makePixelRng(7u, 0u, 0u, 5u);
    for (int i = 0; i < 2000; ++i)
    {
      // A margin of half a voxel outside the box on each side checks the clamping.
      const glm::vec3 p =
        glm::vec3(rng.nextFloat(), rng.nextFloat(), rng.nextFloat()) * glm::vec3(dims) -
        glm::vec3(0.5f);
      const glm::vec3 inside = glm::clamp(p, glm::vec3(0.0f), glm::vec3(dims - 1));
      ASSERT_NEAR(v.scalarAt(p), field(inside), 2.0f * hv::ScalarQuantum)
        << "dims " << dims.x << "x" << dims.y << "x" << dims.z << " at (" << p.x << ", " << p.y
        << ", " << p.z << ")";
      ASSERT_NEAR(v.scalarQuantaAt(p), v.trilinear(v.scalar, p), 1e-3f);
    }
  }
}

TEST(Tracking, IndexRayParameterIsWorldDistance)
{
  hv::VolumeGrid grid;
  makeHomogeneous(grid);
  const hv::VolumeView v = grid.view();
  const hv::ClippingPlanes none{};
  hv::Pcg32 rng = hv::makePixelRng(0u, 0u, 0u, 33u);
  const glm::vec3 centre = 0.5f * (WorldLow + WorldHigh);
  int hits = 0;
  for (int i = 0; i < 2000; ++i)
  {
    const glm::vec3 origin =
      centre + 12.0f * hv::sampleUniformSphere(rng.nextFloat(), rng.nextFloat());
    const glm::vec3 target = WorldLow +
      (WorldHigh - WorldLow) * glm::vec3(rng.nextFloat(), rng.nextFloat(), rng.nextFloat());
    const glm::vec3 direction = glm::normalize(target - origin);
    hv::IndexRay ray;
    ASSERT_TRUE(hv::makeIndexRay(v, none, origin, direction, 0.0f, hv::Infinity, ray));
    ++hits;
    const double chord = hvtest::boxChordLength(
      glm::dvec3(origin), glm::dvec3(direction), glm::dvec3(WorldLow), glm::dvec3(WorldHigh));
    ASSERT_NEAR(ray.tMax - ray.tMin, chord, 1e-4 * (1.0 + chord));
    // Index position at t maps to the world position at t.
    for (float t : { ray.tMin, 0.5f * (ray.tMin + ray.tMax), ray.tMax })
    {
      const glm::vec3 world =
        glm::vec3(v.indexToWorld * glm::vec4(ray.origin + t * ray.direction, 1.0f));
      ASSERT_NEAR(glm::length(world - (origin + t * direction)), 0.0f, 1e-4f);
    }
  }
  EXPECT_EQ(hits, 2000);
  // tMax is honoured, a ray pointing away misses.
  hv::IndexRay ray;
  EXPECT_TRUE(hv::makeIndexRay(v, none, centre, glm::vec3(1, 0, 0), 0.0f, 1.0f, ray));
  EXPECT_FLOAT_EQ(ray.tMax, 1.0f);
  EXPECT_FALSE(hv::makeIndexRay(
    v, none, WorldHigh + glm::vec3(1.0f), glm::vec3(0, 0, 1), 0.0f, hv::Infinity, ray));
}

// Beer-Lambert in a homogeneous box with anisotropic spacing, for rays along each axis, an
// oblique ray and a ray starting inside the medium.
TEST(Tracking, HomogeneousSlabBeerLambert)
{
  hv::VolumeGrid grid;
  makeHomogeneous(grid);
  const hv::VolumeView v = grid.view();
  const double sigma = hvtest::extinctionOf(Alpha, UnitDistance, DensityScale);
  const glm::vec3 centre = 0.5f * (WorldLow + WorldHigh);
  struct Case
  {
    const char* name;
    glm::vec3 origin;
    glm::vec3 direction;
  };
  const Case cases[] = {
    { "slab along +x (d = 7.5)", glm::vec3(WorldLow.x - 3.0f, centre.y, centre.z),
      glm::vec3(1, 0, 0) },
    { "slab along -y (d = 3.75)", glm::vec3(centre.x + 0.3f, WorldHigh.y + 2.0f, centre.z),
      glm::vec3(0, -1, 0) },
    { "slab along +z (d = 11.25)", glm::vec3(centre.x, centre.y, WorldLow.z - 1.0f),
      glm::vec3(0, 0, 1) },
    { "oblique", glm::vec3(WorldLow.x - 1.0f, centre.y - 0.4f, centre.z - 2.0f),
      glm::normalize(glm::vec3(1.0f, 0.1f, 0.3f)) },
    { "starting inside", centre, glm::normalize(glm::vec3(-0.4f, 0.2f, -0.6f)) },
  };
  std::uint32_t stream = 0;
  for (const Case& c : cases)
  {
    const double d = hvtest::boxChordLength(
      glm::dvec3(c.origin), glm::dvec3(c.direction), glm::dvec3(WorldLow), glm::dvec3(WorldHigh));
    ASSERT_GT(d, 1.0) << c.name;
    const double exact = std::exp(-sigma * d);
    const TransmittanceEstimates e =
      estimate(v, hv::ClippingPlanes(), c.origin, c.direction, hv::Infinity, Samples, stream++);
    expectTransmittance(std::string("ratio tracking, ") + c.name, e.ratio, exact);
    expectTransmittance(std::string("delta tracking, ") + c.name, e.delta, exact);
  }
}

// The acceptance criterion proper: shadow rays towards a directional light (and a positional
// one, whose distance must bound the ray) through transmittanceTowards.
TEST(Tracking, TransmittanceTowardsLights)
{
  hv::VolumeGrid grid;
  makeHomogeneous(grid);
  hv::SceneView scene;
  scene.volume = grid.view();
  const double sigma = hvtest::extinctionOf(Alpha, UnitDistance, DensityScale);
  const glm::vec3 centre = 0.5f * (WorldLow + WorldHigh);

  hv::PointLightView sun;
  sun.type = hv::DirectionalLight;
  sun.toLight = glm::normalize(glm::vec3(0.3f, -0.2f, 0.9f));
  hv::PointLightView lamp;
  lamp.type = hv::PositionalLight;
  lamp.position = centre + glm::vec3(3.0f, 0.5f, -2.0f);

  const glm::vec3 x = centre + glm::vec3(-1.0f, 0.3f, -2.5f); // a point inside the medium
  std::uint32_t stream = 100;
  for (const hv::PointLightView& light : { sun, lamp })
  {
    glm::vec3 toLight;
    float distance;
    hv::evaluateLight(light, x, toLight, distance);
    double d = hvtest::boxChordLength(
      glm::dvec3(x), glm::dvec3(toLight), glm::dvec3(WorldLow), glm::dvec3(WorldHigh));
    if (light.type == hv::PositionalLight)
    {
      EXPECT_LT(distance, d) << "the lamp must be inside the medium for this test";
      d = distance;
    }
    d -= hv::RayEpsilon; // shadow rays start RayEpsilon off the scatter point
    const double exact = std::exp(-sigma * d);
    hv::Pcg32 rng = hv::makePixelRng(stream++, 0u, 0u, 34u);
    RunningStats stats;
    for (int i = 0; i < Samples; ++i)
    {
      stats.add(hv::transmittanceTowards(scene, x, toLight, distance, rng));
    }
    expectTransmittance(light.type == hv::DirectionalLight
        ? "transmittanceTowards, directional light"
        : "transmittanceTowards, positional light",
      stats, exact);
  }

  // A shadow ray that never enters the volume is unoccluded.
  hv::Pcg32 rng = hv::makePixelRng(0u, 0u, 0u, 35u);
  EXPECT_EQ(hv::transmittanceTowards(
              scene, WorldHigh + glm::vec3(1.0f), glm::vec3(0, 1, 0), hv::Infinity, rng),
    1.0f);
}

TEST(Tracking, ClippingPlanesShortenThePath)
{
  hv::VolumeGrid grid;
  makeHomogeneous(grid);
  const hv::VolumeView v = grid.view();
  const double sigma = hvtest::extinctionOf(Alpha, UnitDistance, DensityScale);
  const glm::vec3 centre = 0.5f * (WorldLow + WorldHigh);
  const glm::vec3 origin(WorldLow.x - 3.0f, centre.y, centre.z);
  const glm::vec3 direction(1, 0, 0);

  // Keep x >= WorldLow.x + 3 (n.x + d >= 0): 4.5 of the 7.5 remain.
  hv::ClippingPlanes keepRight;
  keepRight.planes[0] = glm::vec4(1, 0, 0, -(WorldLow.x + 3.0f));
  keepRight.count = 1;
  // Additionally keep x <= WorldLow.x + 6.0: 3.0 remain.
  hv::ClippingPlanes keepBand = keepRight;
  keepBand.planes[1] = glm::vec4(-1, 0, 0, WorldLow.x + 6.0f);
  keepBand.count = 2;
  // An oblique plane through the centre, keeping the half towards -x: cuts the ray at centre.x.
  hv::ClippingPlanes oblique;
  const glm::vec3 n = glm::normalize(glm::vec3(-1.0f, 0.5f, 0.2f));
  oblique.planes[0] = glm::vec4(n, -glm::dot(n, centre));
  oblique.count = 1;

  struct Case
  {
    const char* name;
    const hv::ClippingPlanes* clipping;
    double length;
  };
  const Case cases[] = { { "one clipping plane (d = 4.5)", &keepRight, 4.5 },
    { "two clipping planes (d = 3)", &keepBand, 3.0 },
    { "oblique clipping plane (d = 3.75)", &oblique, 3.75 } };
  std::uint32_t stream = 200;
  for (const Case& c : cases)
  {
    hv::IndexRay ray;
    ASSERT_TRUE(hv::makeIndexRay(v, *c.clipping, origin, direction, 0.0f, hv::Infinity, ray));
    EXPECT_NEAR(ray.tMax - ray.tMin, c.length, 1e-4) << c.name;
    const TransmittanceEstimates e =
      estimate(v, *c.clipping, origin, direction, hv::Infinity, Samples, stream++);
    expectTransmittance(
      std::string("ratio tracking, ") + c.name, e.ratio, std::exp(-sigma * c.length));
    expectTransmittance(
      std::string("delta tracking, ") + c.name, e.delta, std::exp(-sigma * c.length));
  }

  // A plane parallel to the ray, with the ray on its clipped side, removes the whole ray.
  hv::ClippingPlanes parallel;
  parallel.planes[0] = glm::vec4(0, 1, 0, -(centre.y + 1.0f));
  parallel.count = 1;
  hv::IndexRay ray;
  EXPECT_FALSE(hv::makeIndexRay(v, parallel, origin, direction, 0.0f, hv::Infinity, ray));
}

TEST(Tracking, CroppingRemovesRegions)
{
  hv::VolumeGrid grid;
  makeHomogeneous(grid);
  const double sigma = hvtest::extinctionOf(Alpha, UnitDistance, DensityScale);
  const glm::vec3 centre = 0.5f * (WorldLow + WorldHigh);
  const glm::vec3 origin(WorldLow.x - 3.0f, centre.y, centre.z);
  // Index-space crop planes at x = 4 and x = 10: 6 voxels = 3 world units along x.
  const glm::vec3 low(4.0f, 3.0f, 3.0f), high(10.0f, 12.0f, 12.0f);

  // Subvolume (only the central region, bit 13): the ray is restricted to the crop box.
  grid.setCropping(true, low, high, 0x2000);
  TransmittanceEstimates e = estimate(
    grid.view(), hv::ClippingPlanes(), origin, glm::vec3(1, 0, 0), hv::Infinity, Samples, 300);
  expectTransmittance("ratio tracking, subvolume crop (d = 3)", e.ratio, std::exp(-sigma * 3.0));
  expectTransmittance("delta tracking, subvolume crop (d = 3)", e.delta, std::exp(-sigma * 3.0));

  // Everything but the central region: the ray crosses 7.5 - 3 = 4.5 of medium.
  grid.setCropping(true, low, high, 0x7ffffff & ~0x2000);
  e = estimate(
    grid.view(), hv::ClippingPlanes(), origin, glm::vec3(1, 0, 0), hv::Infinity, Samples, 301);
  expectTransmittance(
    "ratio tracking, central region cropped (d = 4.5)", e.ratio, std::exp(-sigma * 4.5));
  expectTransmittance(
    "delta tracking, central region cropped (d = 4.5)", e.delta, std::exp(-sigma * 4.5));
}

// Scalar = linear ramp in x, opacity table (0, alpha): sigmaT(x) grows linearly from 0 to
// sigmaMax across the box, so the optical depth of a chord is d * sigmaMax * (s_in + s_out) / 2.
TEST(Tracking, LinearRampOpticalDepth)
{
  hv::VolumeGrid grid;
  grid.setCellSize(4);
  grid.setIndexToWorld(indexToWorld());
  grid.setScalars(
    Dims, hvtest::sampleField(Dims, [](const glm::vec3& p) { return p.x / (Dims.x - 1); }));
  const float alphaMax = 0.17f;
  grid.setTransferFunction({ 0.0f, alphaMax }, std::vector<float>(6, 1.0f), 1.0f, 1.0f);
  const hv::VolumeView v = grid.view();
  const double sigmaMax = hvtest::extinctionOf(alphaMax, 1.0, 1.0);
  const glm::vec3 centre = 0.5f * (WorldLow + WorldHigh);
  auto ramp = [](const glm::dvec3& p) { return (p.x - WorldLow.x) / (WorldHigh.x - WorldLow.x); };

  struct Case
  {
    const char* name;
    glm::vec3 origin;
    glm::vec3 direction;
  };
  const Case cases[] = {
    { "ramp along +x", glm::vec3(WorldLow.x - 1.0f, centre.y, centre.z), glm::vec3(1, 0, 0) },
    { "ramp along -x", glm::vec3(WorldHigh.x + 1.0f, centre.y + 0.2f, centre.z),
      glm::vec3(-1, 0, 0) },
    { "ramp oblique", glm::vec3(WorldLow.x - 1.0f, centre.y - 0.5f, centre.z - 3.0f),
      glm::normalize(glm::vec3(1.0f, 0.05f, 0.6f)) },
    { "ramp along z at s = 1/3", glm::vec3(WorldLow.x + 2.5f, centre.y, WorldLow.z - 1.0f),
      glm::vec3(0, 0, 1) },
  };
  std::uint32_t stream = 400;
  for (const Case& c : cases)
  {
    hv::IndexRay ray;
    ASSERT_TRUE(
      hv::makeIndexRay(v, hv::ClippingPlanes(), c.origin, c.direction, 0.0f, hv::Infinity, ray));
    const glm::dvec3 o(c.origin), dir(c.direction);
    const double tau = (ray.tMax - ray.tMin) * sigmaMax * 0.5 *
      (ramp(o + double(ray.tMin) * dir) + ramp(o + double(ray.tMax) * dir));
    const TransmittanceEstimates e =
      estimate(v, hv::ClippingPlanes(), c.origin, c.direction, hv::Infinity, Samples, stream++);
    expectTransmittance(std::string("ratio tracking, ") + c.name, e.ratio, std::exp(-tau));
    expectTransmittance(std::string("delta tracking, ") + c.name, e.delta, std::exp(-tau));
  }
}

// Delta tracking samples collisions with density sigmaT(t) exp(-tau(t)): along the ramp the
// conditional CDF of the collision distance s is (1 - exp(-tau(s))) / (1 - exp(-tau(d))) with
// tau(s) = sigmaMax (s0 s + (s1 - s0) s^2 / (2 d)). Kolmogorov-Smirnov test at 1e-4.
TEST(Tracking, FreeFlightDistanceDistribution)
{
  hv::VolumeGrid grid;
  grid.setCellSize(4);
  grid.setIndexToWorld(indexToWorld());
  grid.setScalars(
    Dims, hvtest::sampleField(Dims, [](const glm::vec3& p) { return p.x / (Dims.x - 1); }));
  grid.setTransferFunction({ 0.0f, 0.3f }, std::vector<float>(6, 1.0f), 1.0f, 1.0f);
  const hv::VolumeView v = grid.view();
  const double sigmaMax = hvtest::extinctionOf(0.3, 1.0, 1.0);
  const glm::vec3 centre = 0.5f * (WorldLow + WorldHigh);
  hv::IndexRay ray;
  ASSERT_TRUE(hv::makeIndexRay(v, hv::ClippingPlanes(),
    glm::vec3(WorldLow.x - 1.0f, centre.y, centre.z), glm::vec3(1, 0, 0), 0.0f, hv::Infinity, ray));
  const double d = ray.tMax - ray.tMin;
  auto tau = [&](double s) { return sigmaMax * s * s / (2.0 * d); }; // s0 = 0, s1 = 1
  hv::Pcg32 rng = hv::makePixelRng(0u, 0u, 0u, 36u);
  std::vector<double> cdf;
  int escaped = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i)
  {
    float t;
    if (hv::sampleFreeFlight(v, ray, rng, t))
    {
      ASSERT_GE(t, ray.tMin);
      ASSERT_LE(t, ray.tMax);
      cdf.push_back((1.0 - std::exp(-tau(t - ray.tMin))) / (1.0 - std::exp(-tau(d))));
    }
    else
    {
      ++escaped;
    }
  }
  std::sort(cdf.begin(), cdf.end());
  double ks = 0.0;
  for (std::size_t i = 0; i < cdf.size(); ++i)
  {
    ks =
      std::max(ks, std::max(cdf[i] - double(i) / cdf.size(), double(i + 1) / cdf.size() - cdf[i]));
  }
  EXPECT_LT(ks, 2.23 / std::sqrt(double(cdf.size()))) << "collision-distance distribution";
  const double p = std::exp(-tau(d));
  EXPECT_NEAR(escaped, n * p, 5.0 * std::sqrt(n * p * (1.0 - p)));
}

// A smooth but non-trivial field under a piecewise-linear transfer function: the reference
// optical depth is the numerical integral of VolumeView::sigmaT itself along the ray (midpoint
// rule, 2e5 steps, double accumulation: the quadrature error is ~1e-8 relative).
TEST(Tracking, HeterogeneousOpticalDepth)
{
  hv::VolumeGrid grid;
  grid.setCellSize(4);
  grid.setIndexToWorld(indexToWorld());
  grid.setScalars(Dims,
    hvtest::sampleField(Dims,
      [](const glm::vec3& p) {
        return 0.5f + 0.45f * std::sin(0.55f * p.x + 0.3f) * std::cos(0.35f * p.y - 0.25f * p.z);
      }));
  const std::vector<float> opacity = { 0.0f, 0.3f, 0.05f, 0.6f, 0.2f, 0.4f };
  const std::vector<float> albedo(opacity.size() * 3, 1.0f);
  const glm::vec3 centre = 0.5f * (WorldLow + WorldHigh);
  struct Case
  {
    const char* name;
    glm::vec3 origin;
    glm::vec3 direction;
  };
  const Case cases[] = {
    { "heterogeneous, along +x", glm::vec3(WorldLow.x - 1.0f, centre.y + 0.3f, centre.z - 0.7f),
      glm::vec3(1, 0, 0) },
    { "heterogeneous, oblique", glm::vec3(WorldHigh.x + 1.0f, centre.y, WorldHigh.z + 1.0f),
      glm::normalize(glm::vec3(-0.5f, 0.02f, -1.0f)) },
  };
  std::uint32_t stream = 500;
  for (const Case& c : cases)
  {
    auto opticalDepth = [&](const hv::VolumeView& v)
    {
      hv::IndexRay ray;
      EXPECT_TRUE(
        hv::makeIndexRay(v, hv::ClippingPlanes(), c.origin, c.direction, 0.0f, hv::Infinity, ray));
      const int steps = 200000;
      const double h = (ray.tMax - ray.tMin) / steps;
      double tau = 0.0;
      for (int i = 0; i < steps; ++i)
      {
        const float t = static_cast<float>(ray.tMin + (i + 0.5) * h);
        tau += v.sigmaT(ray.origin + t * ray.direction) * h;
      }
      return tau;
    };
    // Scale the density so that the optical depth is 0.7 (transmittance ~0.5).
    grid.setTransferFunction(opacity, albedo, 1.0f, 1.0f);
    const float densityScale = static_cast<float>(0.7 / opticalDepth(grid.view()));
    grid.setTransferFunction(opacity, albedo, 1.0f, densityScale);
    const hv::VolumeView v = grid.view();
    const double tau = opticalDepth(v);
    const TransmittanceEstimates e =
      estimate(v, hv::ClippingPlanes(), c.origin, c.direction, hv::Infinity, Samples, stream++);
    expectTransmittance(std::string("ratio tracking, ") + c.name, e.ratio, std::exp(-tau));
    expectTransmittance(std::string("delta tracking, ") + c.name, e.delta, std::exp(-tau));
  }
}

TEST(Tracking, EmptyMediumIsTransparent)
{
  hv::VolumeGrid grid;
  grid.setIndexToWorld(indexToWorld());
  grid.setScalars(
    Dims, std::vector<float>(static_cast<std::size_t>(Dims.x) * Dims.y * Dims.z, 0.3f));
  hvtest::setConstantTransferFunction(grid, 0.0f, glm::vec3(1.0f), 1.0f, 1.0f);
  EXPECT_TRUE(grid.isTransparent());
  const hv::VolumeView v = grid.view();
  const glm::vec3 centre = 0.5f * (WorldLow + WorldHigh);
  hv::IndexRay ray;
  // A ray through a medium with nothing in it may be culled outright (the occupied box is
  // empty); that is transparency too.
  if (!hv::makeIndexRay(v, hv::ClippingPlanes(), glm::vec3(WorldLow.x - 1.0f, centre.y, centre.z),
        glm::vec3(1, 0, 0), 0.0f, hv::Infinity, ray))
  {
    SUCCEED();
    return;
  }
  hv::Pcg32 rng = hv::makePixelRng(0u, 0u, 0u, 37u);
  float t;
  for (int i = 0; i < 100; ++i)
  {
    EXPECT_EQ(hv::estimateTransmittance(v, ray, rng), 1.0f);
    EXPECT_FALSE(hv::sampleFreeFlight(v, ray, rng, t));
  }
}

// For random points in a random volume under a random piecewise transfer function (with and
// without gradient opacity), sigmaT(p) never exceeds the majorant of the cell containing p.
TEST(Majorant, BoundsExtinctionEverywhere)
{
  hv::Pcg32 rng = hv::makePixelRng(0u, 0u, 0u, 38u);
  const glm::ivec3 dims(23, 17, 30); // not multiples of any cell size
  std::vector<float> scalars(static_cast<std::size_t>(dims.x) * dims.y * dims.z);
  for (float& s : scalars)
  {
    s = rng.nextFloat();
  }
  // Some smooth structure too: blocks of constant value next to noise.
  for (int k = 0; k < 10; ++k)
  {
    for (int j = 0; j < dims.y; ++j)
    {
      for (int i = 0; i < dims.x; ++i)
      {
        scalars[(static_cast<std::size_t>(k) * dims.y + j) * dims.x + i] = 0.37f;
      }
    }
  }
  for (int cellSize : { 1, 3, 4, 8 })
  {
    for (bool gradientOpacity : { false, true })
    {
      hv::VolumeGrid grid;
      grid.setCellSize(cellSize);
      grid.setIndexToWorld(glm::scale(glm::mat4(1.0f), glm::vec3(0.3f, 0.7f, 0.2f)));
      grid.setScalars(dims, scalars);
      const int nodes = 2 + static_cast<int>(rng.nextFloat() * 30.0f);
      std::vector<float> opacity(nodes);
      for (float& a : opacity)
      {
        a = rng.nextFloat() < 0.3f ? 0.0f : rng.nextFloat();
      }
      grid.setTransferFunction(opacity, std::vector<float>(3 * nodes, 0.8f), 0.5f, 3.0f);
      if (gradientOpacity)
      {
        std::vector<float> table(5);
        for (float& g : table)
        {
          g = rng.nextFloat();
        }
        grid.setGradientOpacity(table, 4.0f, 1.0f);
      }
      const hv::VolumeView v = grid.view();
      ASSERT_EQ(v.gradientOpacity != nullptr, gradientOpacity);
      ASSERT_EQ(v.majorantDims, (dims - 1) / cellSize + 1);
      int violations = 0;
      for (int i = 0; i < 100000; ++i)
      {
        glm::vec3 p =
          glm::vec3(rng.nextFloat(), rng.nextFloat(), rng.nextFloat()) * glm::vec3(dims - 1);
        if (i % 4 == 0)
        {
          // On a cell boundary: both neighbouring cells must bound it (the DDA may report either).
          p.x = std::round(p.x / cellSize) * cellSize;
          p.x = std::min(p.x, static_cast<float>(dims.x - 1));
        }
        const float sigma = v.sigmaT(p);
        const glm::ivec3 cell =
          glm::min(glm::ivec3(glm::floor(p / static_cast<float>(cellSize))), v.majorantDims - 1);
        if (sigma > v.majorantOfCell(cell))
        {
          ++violations;
        }
        if (i % 4 == 0 && cell.x > 0 && p.x == cell.x * cellSize)
        {
          if (sigma > v.majorantOfCell(cell - glm::ivec3(1, 0, 0)))
          {
            ++violations;
          }
        }
      }
      EXPECT_EQ(violations, 0) << "cell size " << cellSize << ", gradient opacity "
                               << gradientOpacity;
    }
  }
}

TEST(Majorant, EmptyCellsHaveZeroMajorant)
{
  // Voxels x <= 16 are 0 (fully transparent under the table), the others 1.
  const glm::ivec3 dims(32, 8, 8);
  hv::VolumeGrid grid;
  grid.setCellSize(8);
  grid.setScalars(
    dims, hvtest::sampleField(dims, [](const glm::vec3& p) { return p.x <= 16.0f ? 0.0f : 1.0f; }));
  grid.setTransferFunction({ 0.0f, 0.5f }, std::vector<float>(6, 1.0f), 1.0f, 1.0f);
  EXPECT_FALSE(grid.isTransparent());
  const hv::VolumeView v = grid.view();
  // Cell c covers the closed index range [8c, 8c + 8] (what trilinear lookups inside it read):
  // cells 0 and 1 read only zeros and are skipped as empty; cell 2 reads ones.
  EXPECT_EQ(v.majorantOfCell(glm::ivec3(0, 0, 0)), 0.0f);
  EXPECT_EQ(v.majorantOfCell(glm::ivec3(1, 0, 0)), 0.0f);
  EXPECT_GE(
    v.majorantOfCell(glm::ivec3(2, 0, 0)), static_cast<float>(hvtest::extinctionOf(0.5, 1.0, 1.0)));
}

// Switching gradient opacity off again (an empty table, as vtkPathTracedVolumeMapper passes
// when the property's gradient opacity is disabled) must restore majorants that bound the
// now unattenuated extinction, and must not leave cells flagged empty where the medium is not.
TEST(Majorant, BoundsExtinctionAfterDisablingGradientOpacity)
{
  const glm::ivec3 dims(24, 24, 24);
  hv::VolumeGrid grid;
  grid.setCellSize(4);
  // A ball of 1 in 0: zero gradient (hence a gradient-opacity factor of ~0) away from its rim.
  grid.setScalars(dims,
    hvtest::sampleField(dims,
      [](const glm::vec3& p) { return glm::length(p - glm::vec3(11.5f)) <= 8.0f ? 1.0f : 0.0f; }));
  grid.setTransferFunction({ 0.2f, 0.6f }, std::vector<float>(6, 1.0f), 1.0f, 1.0f);
  // Gradient opacity 0 for flat regions, 1 for strong gradients.
  grid.setGradientOpacity({ 0.0f, 1.0f }, 0.5f, 1.0f);
  ASSERT_NE(grid.view().gradientOpacity, nullptr);
  // ... and off again, then the transfer function re-applied (the mapper's order).
  grid.setTransferFunction({ 0.2f, 0.6f }, std::vector<float>(6, 1.0f), 1.0f, 1.0f);
  grid.setGradientOpacity({}, 0.5f, 1.0f);
  const hv::VolumeView v = grid.view();
  ASSERT_EQ(v.gradientOpacity, nullptr);
  hv::Pcg32 rng = hv::makePixelRng(0u, 0u, 0u, 39u);
  int violations = 0;
  float worst = 0.0f;
  for (int i = 0; i < 20000; ++i)
  {
    const glm::vec3 p =
      glm::vec3(rng.nextFloat(), rng.nextFloat(), rng.nextFloat()) * glm::vec3(dims - 1);
    const glm::ivec3 cell = glm::min(glm::ivec3(glm::floor(p / 4.0f)), v.majorantDims - 1);
    const float sigma = v.sigmaT(p);
    if (sigma > v.majorantOfCell(cell))
    {
      ++violations;
      worst = std::max(worst, sigma - v.majorantOfCell(cell));
    }
  }
  EXPECT_EQ(violations, 0) << "largest excess of sigmaT over the majorant: " << worst;
}

// Moving or turning the volume keeps the world gradient magnitudes (no per-voxel recompute,
// which would stall every frame of a hand-held hologram); scaling changes them by the scale.
TEST(VolumeGrid, GradientMagnitudesFollowScaleButNotRotation)
{
  hv::VolumeGrid grid;
  const glm::ivec3 dims(12, 10, 8);
  std::vector<float> ramp(static_cast<std::size_t>(dims.x) * dims.y * dims.z);
  for (int k = 0; k < dims.z; ++k)
  {
    for (int j = 0; j < dims.y; ++j)
    {
      for (int i = 0; i < dims.x; ++i)
      {
        ramp[(static_cast<std::size_t>(k) * dims.y + j) * dims.x + i] = 0.05f * i + 0.02f * j;
      }
    }
  }
  grid.setScalars(dims, ramp);
  const float original = grid.maximumGradientMagnitude();
  const glm::mat4 rotated = glm::translate(glm::mat4(1.0f), glm::vec3(3, -2, 7)) *
    glm::rotate(glm::mat4(1.0f), 0.7f, glm::normalize(glm::vec3(1, 2, 3)));
  EXPECT_FALSE(grid.setIndexToWorld(rotated));
  EXPECT_FLOAT_EQ(grid.maximumGradientMagnitude(), original);
  EXPECT_TRUE(grid.setIndexToWorld(glm::scale(rotated, glm::vec3(2.0f))));
  EXPECT_NEAR(grid.maximumGradientMagnitude(), 0.5f * original, 1e-4f * original);
}

// The mapper gives the grid a new volume's scalars with their matrix, so that the largest
// gradient magnitude is searched for once, under that matrix: it must equal what scalars and then
// the matrix give, and the same matrix again must not search again.
TEST(VolumeGrid, ScalarsWithTheirMatrixGiveTheSameMaximumGradient)
{
  const glm::ivec3 dims(9, 7, 6);
  std::vector<float> scalars(static_cast<std::size_t>(dims.x) * dims.y * dims.z);
  hv::VolumeGrid::ScalarArray quantized(scalars.size());
  for (std::size_t v = 0; v < scalars.size(); ++v)
  {
    scalars[v] = 0.5f + 0.4f * std::sin(0.9f * static_cast<float>(v % 17) + 0.3f * (v / 63));
    quantized[v] = hv::VolumeGrid::quantize(scalars[v]);
  }
  const glm::mat4 spacing = glm::scale(glm::mat4(1.0f), glm::vec3(0.4f, 0.9f, 2.5f));
  hv::VolumeGrid scalarsFirst;
  scalarsFirst.setScalars(dims, scalars);
  EXPECT_TRUE(scalarsFirst.setIndexToWorld(spacing));
  hv::VolumeGrid together;
  together.setQuantizedScalars(dims, std::move(quantized), spacing);
  EXPECT_FALSE(together.setIndexToWorld(spacing));
  EXPECT_EQ(together.maximumGradientMagnitude(), scalarsFirst.maximumGradientMagnitude());
  EXPECT_GT(together.maximumGradientMagnitude(), 0.0f);
  // New scalars under the same matrix keep it.
  together.setScalars(dims, scalars);
  EXPECT_FALSE(together.setIndexToWorld(spacing));
  EXPECT_EQ(together.maximumGradientMagnitude(), scalarsFirst.maximumGradientMagnitude());
}

namespace
{
// A sparse random occupancy: scalar 1 in a few small blobs, 0 elsewhere, under a table that
// gives 0 no extinction, with 2-voxel macrocells as the mapper uses.
void makeSparseBlobs(hv::VolumeGrid& grid, const glm::ivec3& dims, std::uint32_t seed)
{
  hv::Pcg32 rng = hv::makePixelRng(0u, 0u, 0u, seed);
  std::vector<glm::vec3> centres(6);
  for (glm::vec3& c : centres)
  {
    c = glm::vec3(rng.nextFloat(), rng.nextFloat(), rng.nextFloat()) * glm::vec3(dims - 1);
  }
  grid.setCellSize(2);
  grid.setIndexToWorld(indexToWorld());
  grid.setScalars(dims,
    hvtest::sampleField(dims,
      [&](const glm::vec3& p)
      {
        for (const glm::vec3& c : centres)
        {
          if (glm::length(p - c) < 1.5f)
          {
            return 1.0f;
          }
        }
        return 0.0f;
      }));
  grid.setTransferFunction({ 0.0f, 0.5f }, std::vector<float>(6, 1.0f), 1.0f, 1.0f);
}
}

// The distance map of each ray octant is the exact Chebyshev distance from an empty cell to
// the nearest non-empty cell in the orthant ahead of it (checked against brute force).
TEST(Majorant, OctantDistanceMapsAreExact)
{
  const glm::ivec3 dims(23, 17, 30);
  hv::VolumeGrid grid;
  makeSparseBlobs(grid, dims, 51u);
  const hv::VolumeView v = grid.view();
  ASSERT_NE(v.emptyDistance, nullptr);
  const glm::ivec3 n = v.majorantDims;
  std::vector<glm::ivec3> cells, occupied;
  for (int z = 0; z < n.z; ++z)
  {
    for (int y = 0; y < n.y; ++y)
    {
      for (int x = 0; x < n.x; ++x)
      {
        cells.emplace_back(x, y, z);
        if (v.majorantOfCell(cells.back()) > 0.0f)
        {
          occupied.push_back(cells.back());
        }
      }
    }
  }
  ASSERT_GT(occupied.size(), 5u);
  ASSERT_LT(occupied.size(), static_cast<std::size_t>(n.x * n.y * n.z) / 4);
  int mismatches = 0, leapable = 0;
  for (int octant = 0; octant < 8; ++octant)
  {
    const glm::ivec3 s((octant & 1) ? -1 : 1, (octant & 2) ? -1 : 1, (octant & 4) ? -1 : 1);
    for (const glm::ivec3& c : cells)
    {
      int expected = 255;
      for (const glm::ivec3& o : occupied)
      {
        const glm::ivec3 ahead = (o - c) * s;
        if (ahead.x >= 0 && ahead.y >= 0 && ahead.z >= 0)
        {
          expected = std::min(expected, std::max(ahead.x, std::max(ahead.y, ahead.z)));
        }
      }
      mismatches += v.emptyDistanceOfCell(c, octant) != expected ? 1 : 0;
      leapable += expected > 1 ? 1 : 0;
    }
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(leapable, 0); // the test exercises leaps at all
}

// Leaping over empty space must not change which non-empty cells a ray visits: the iterator
// with the distance maps yields the same non-empty cells and entry points as plain 3D-DDA,
// except cells a ray only grazes for less than 0.1 % of a cell (the leap lands a hair past
// the face of the empty box).
TEST(Majorant, LeapsVisitTheSameNonEmptyCellsAsPlainTraversal)
{
  const glm::ivec3 dims(23, 17, 30);
  hv::VolumeGrid grid;
  makeSparseBlobs(grid, dims, 52u);
  const hv::VolumeView withLeaps = grid.view();
  hv::VolumeView plain = withLeaps;
  plain.emptyDistance = nullptr;
  struct Visit
  {
    glm::ivec3 cell;
    float entry, exit;
  };
  auto visits = [](const hv::VolumeView& v, const hv::IndexRay& ray, int& segments)
  {
    std::vector<Visit> result;
    hv::MajorantIterator it;
    it.begin(v, ray);
    float exit, majorant;
    segments = 0;
    while (it.segment(v, exit, majorant))
    {
      ++segments;
      if (majorant > 0.0f)
      {
        result.push_back({ it.cell, it.t, exit });
      }
      it.advance(v, majorant);
    }
    return result;
  };
  hv::Pcg32 rng = hv::makePixelRng(0u, 0u, 0u, 53u);
  const glm::vec3 centre = 0.5f *
    (glm::vec3(indexToWorld() * glm::vec4(0, 0, 0, 1)) +
      glm::vec3(indexToWorld() * glm::vec4(glm::vec3(dims - 1), 1)));
  int rays = 0, segmentsPlain = 0, segmentsLeaping = 0, visited = 0;
  for (int i = 0; i < 4000; ++i)
  {
    const glm::vec3 direction = hv::sampleUniformSphere(rng.nextFloat(), rng.nextFloat());
    const glm::vec3 offset =
      glm::vec3(rng.nextFloat(), rng.nextFloat(), rng.nextFloat()) * 6.0f - 3.0f;
    const glm::vec3 origin = centre + offset - 20.0f * direction;
    hv::IndexRay ray;
    if (!hv::makeIndexRay(
          withLeaps, hv::ClippingPlanes(), origin, direction, 0.0f, hv::Infinity, ray))
    {
      continue;
    }
    ++rays;
    int a = 0, b = 0;
    const std::vector<Visit> expected = visits(plain, ray, a);
    const std::vector<Visit> actual = visits(withLeaps, ray, b);
    segmentsPlain += a;
    segmentsLeaping += b;
    std::size_t j = 0;
    for (const Visit& e : expected)
    {
      while (j < actual.size() && actual[j].cell != e.cell)
      {
        ++j;
      }
      const bool grazed = e.exit - e.entry < 1e-3f * 2.0f;
      if (j == actual.size())
      {
        ASSERT_TRUE(grazed) << "ray " << i << " leapt over a non-empty cell";
        j = 0;
        continue;
      }
      EXPECT_NEAR(actual[j].entry, e.entry, 1e-3f) << "ray " << i;
      EXPECT_NEAR(actual[j].exit, e.exit, 1e-4f) << "ray " << i;
      ++visited;
    }
  }
  std::printf("[ info ] %d rays: %d segments with leaps, %d without; %d non-empty visits\n", rays,
    segmentsLeaping, segmentsPlain, visited);
  EXPECT_GT(rays, 3000);
  EXPECT_GT(visited, 100);
  EXPECT_LT(segmentsLeaping, segmentsPlain / 2); // the leaps do skip
}
