// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// The per-pixel renderer (Render.h): white furnace of the path tracer, determinism, and the
// ray-marched reference models against Beer-Lambert.
#include "KernelTestUtilities.h"

#include "hv/EnvironmentMap.h"
#include "hv/Render.h"
#include "hv/VolumeGrid.h"

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace
{
using hvtest::FurnaceRadiance;
using hvtest::furnaceScene;
using hvtest::makeBall;
using hvtest::makeEye;
using hvtest::RunningStats;

struct FurnaceResult
{
  RunningStats pixels[3];          // per RGB channel, one entry per (pixel, frame) estimate
  double coverage = 0.0;           // fraction of primary samples that collided (pixel hits)
  RunningStats surfaceProbability; // of the first scatter event, from its gradient magnitude
};

// Renders the pixels inside the ball's projected disc (6 of its ~9.3 pixels of radius, so
// nearly every primary ray enters the medium) for a few frames; every renderPixel result is one
// estimate of the pixel's radiance.
FurnaceResult renderFurnace(const hv::SceneView& scene, int samplesPerPixel, int frames)
{
  const int size = 32;
  const hv::EyeView eye =
    makeEye(glm::lookAt(glm::vec3(0.0f, 0.3f, 2.5f), glm::vec3(0.0f), glm::vec3(0, 1, 0)),
      glm::perspective(glm::radians(30.0f), 1.0f, 0.1f, 10.0f), size, size);
  FurnaceResult result;
  int hits = 0, count = 0;
  for (int y = 0; y < size; ++y)
  {
    for (int x = 0; x < size; ++x)
    {
      if (glm::length(glm::vec2(x + 0.5f, y + 0.5f) - glm::vec2(0.5f * size)) > 6.0f)
      {
        continue;
      }
      for (int frame = 0; frame < frames; ++frame)
      {
        const hv::PixelResult p = hv::renderPixel(
          scene, eye, x, y, 0u, static_cast<std::uint32_t>(frame), 1234u, samplesPerPixel);
        for (int c = 0; c < 3; ++c)
        {
          result.pixels[c].add(p.radiance[c]);
        }
        hits += p.hit;
        ++count;
        if (p.hit)
        {
          result.surfaceProbability.add(
            1.0 - std::exp(-scene.volume.surfaceFactor * p.gradientMagnitude));
        }
      }
    }
  }
  result.coverage = static_cast<double>(hits) / count;
  return result;
}

// An equirectangular RGB map of radiance `sky` with a bright rectangle of texels
// [patch.x, patch.z) x [patch.y, patch.w) (columns x rows).
std::vector<float> skyWithPatch(
  int width, int height, const glm::ivec4& patch, const glm::vec3& bright, const glm::vec3& sky)
{
  std::vector<float> rgb(static_cast<std::size_t>(width) * height * 3);
  for (int row = 0; row < height; ++row)
  {
    for (int column = 0; column < width; ++column)
    {
      const bool inside = column >= patch.x && column < patch.z && row >= patch.y && row < patch.w;
      const glm::vec3 value = inside ? bright : sky;
      const std::size_t t = static_cast<std::size_t>(row) * width + column;
      for (int c = 0; c < 3; ++c)
      {
        rgb[3 * t + c] = value[c];
      }
    }
  }
  return rgb;
}

// A directional light from the upper left besides the environment, for the tests of what
// shadow rays and light sampling do.
void addDirectionalLight(hv::SceneView& scene)
{
  scene.lightCount = 1;
  scene.lights[0].type = hv::DirectionalLight;
  scene.lights[0].toLight = glm::normalize(glm::vec3(-1, 2, 1));
  scene.lights[0].intensity = glm::vec3(0.6f, 0.6f, 0.5f);
}
}

// Acceptance criterion (white furnace): a non-absorbing medium under a uniform environment of
// radiance L renders L within 1 %. Each case asserts, per channel, |mean - L| < 1 % of L and
// < 5 standard errors (the standard error is that of the mean over 1344 independent pixel
// estimates of 256 paths each, 344k paths in all), and that 5 standard errors are below 1 %,
// so the test can resolve a 1 % energy loss or gain.
TEST(Render, WhiteFurnace)
{
  hv::EnvironmentMap environment;
  environment.setUniformRadiance(FurnaceRadiance);
  struct Case
  {
    const char* name;
    float anisotropy;
    float surfaceFactor;
  };
  const Case cases[] = {
    { "isotropic phase function", 0.0f, 0.0f },
    { "forward HG g = 0.6", 0.6f, 0.0f },
    { "backward HG g = -0.4", -0.4f, 0.0f },
    { "hybrid, surface factor 20 (Lambertian)", 0.0f, 20.0f },
  };
  for (const Case& c : cases)
  {
    hv::VolumeGrid grid;
    makeBall(grid, glm::vec3(1.0f));
    grid.setSurfaceFactor(c.surfaceFactor);
    hv::SceneView scene = furnaceScene(grid, environment);
    scene.anisotropy = c.anisotropy;
    const FurnaceResult r = renderFurnace(scene, 256, 12);
    EXPECT_GT(r.coverage, 0.99) << c.name << ": the pixels must look at the medium";
    if (c.surfaceFactor > 0.0f)
    {
      // The hybrid case must really exercise surface events: at the first scatter event
      // (near the ball's boundary, where gradients are strong) about half are surface events.
      std::printf(
        "[ info ] furnace, %-40s mean surface-event probability at the first event %.3f\n", c.name,
        r.surfaceProbability.mean());
      EXPECT_GT(r.surfaceProbability.mean(), 0.4) << c.name;
    }
    for (int channel = 0; channel < 3; ++channel)
    {
      const RunningStats& s = r.pixels[channel];
      const double L = FurnaceRadiance[channel];
      if (channel == 1)
      {
        std::printf(
          "[ info ] furnace, %-40s mean %.5f (L = %.1f), std. error %.5f, relative error %+.3f %%, "
          "%zu pixel estimates x 256 paths\n",
          c.name, s.mean(), L, s.standardError(), 100.0 * (s.mean() - L) / L, s.count());
      }
      EXPECT_LT(5.0 * s.standardError(), 0.01 * L) << c.name << ": too few samples for a 1 % test";
      EXPECT_NEAR(s.mean(), L, 0.01 * L) << c.name << ", channel " << channel;
      EXPECT_NEAR(s.mean(), L, 5.0 * s.standardError()) << c.name << ", channel " << channel;
    }
  }

  // Albedo 0.5 absorbs: clearly less than L (the exact value depends on the geometry).
  hv::VolumeGrid grey;
  makeBall(grey, glm::vec3(0.5f));
  const FurnaceResult r = renderFurnace(furnaceScene(grey, environment), 32, 1);
  std::printf("[ info ] furnace, albedo 0.5: mean %.4f (L = 1)\n", r.pixels[1].mean());
  for (int channel = 0; channel < 3; ++channel)
  {
    EXPECT_LT(r.pixels[channel].mean(), 0.75 * FurnaceRadiance[channel]);
    EXPECT_GT(r.pixels[channel].mean(), 0.0);
  }
}

TEST(Render, Determinism)
{
  hv::VolumeGrid grid;
  makeBall(grid, glm::vec3(0.9f, 0.6f, 0.3f));
  grid.setSurfaceFactor(2.0f);
  hv::EnvironmentMap environment;
  std::vector<float> rgb(16 * 8 * 3);
  hv::Pcg32 fill = hv::makePixelRng(0u, 0u, 0u, 61u);
  for (float& v : rgb)
  {
    v = 3.0f * fill.nextFloat();
  }
  ASSERT_EQ(environment.setRadiance(16, 8, rgb), "");
  hv::SceneView scene = furnaceScene(grid, environment);
  scene.maximumBounces = 8;
  scene.anisotropy = 0.3f;
  scene.lightCount = 1;
  scene.lights[0].type = hv::DirectionalLight;
  scene.lights[0].toLight = glm::normalize(glm::vec3(1, 1, 1));
  const hv::EyeView eye =
    makeEye(glm::lookAt(glm::vec3(0.0f, 0.3f, 2.5f), glm::vec3(0.0f), glm::vec3(0, 1, 0)),
      glm::perspective(glm::radians(30.0f), 1.0f, 0.1f, 10.0f), 32, 32);

  auto same = [](const hv::PixelResult& a, const hv::PixelResult& b)
  {
    return std::memcmp(&a.radiance, &b.radiance, sizeof(a.radiance)) == 0 &&
      std::memcmp(
        &a.firstScatterPosition, &b.firstScatterPosition, sizeof(a.firstScatterPosition)) == 0 &&
      std::memcmp(&a.depth, &b.depth, sizeof(a.depth)) == 0 &&
      std::memcmp(&a.albedo, &b.albedo, sizeof(a.albedo)) == 0 &&
      std::memcmp(&a.normal, &b.normal, sizeof(a.normal)) == 0 &&
      std::memcmp(&a.gradientMagnitude, &b.gradientMagnitude, sizeof(a.gradientMagnitude)) == 0 &&
      std::memcmp(&a.scalar, &b.scalar, sizeof(a.scalar)) == 0 && a.hit == b.hit;
  };
  for (int model :
    { hv::PathTraced, hv::EmissionAbsorption, hv::GradientPhong, hv::PrefilteredEnvironment })
  {
    scene.model = model;
    scene.stepLength = 0.01f;
    // Bit-identical twice, also with other pixels rendered in between (no hidden state).
    const hv::PixelResult a = hv::renderPixel(scene, eye, 15, 17, 1u, 3u, 42u, 8);
    const hv::PixelResult other = hv::renderPixel(scene, eye, 16, 17, 1u, 3u, 42u, 8);
    const hv::PixelResult b = hv::renderPixel(scene, eye, 15, 17, 1u, 3u, 42u, 8);
    EXPECT_TRUE(same(a, b)) << "model " << model;
    EXPECT_EQ(a.hit, 1) << "model " << model;
    // A different seed, frame or eye gives a different estimate.
    const hv::PixelResult c = hv::renderPixel(scene, eye, 15, 17, 1u, 3u, 43u, 8);
    const hv::PixelResult d = hv::renderPixel(scene, eye, 15, 17, 1u, 4u, 42u, 8);
    const hv::PixelResult e = hv::renderPixel(scene, eye, 15, 17, 0u, 3u, 42u, 8);
    EXPECT_FALSE(same(a, c)) << "model " << model;
    EXPECT_FALSE(same(a, d)) << "model " << model;
    EXPECT_FALSE(same(a, e)) << "model " << model;
    (void)other;
  }
}

// Ray-marched models on a homogeneous box (sigmaT = 1.5 per world unit, depth d = 1 along the
// orthographic view rays): emission-absorption gives c (1 - exp(-sigmaT d)) and alpha
// 1 - exp(-sigmaT d). The 2 % tolerance covers the quadrature of a 0.005 step (the jittered
// lattice has d / step = 200 samples per ray) and the early termination at transmittance 1e-3.
TEST(Render, RayMarchedModelsMatchBeerLambert)
{
  const glm::ivec3 dims(16);
  const float voxel = 1.0f / 15.0f;
  const double sigma = 1.5;
  const glm::vec3 albedo(0.9f, 0.5f, 0.2f);
  hv::VolumeGrid grid;
  grid.setIndexToWorld(
    glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(-0.5f)), glm::vec3(voxel)));
  grid.setScalars(dims, std::vector<float>(16 * 16 * 16, 1.0f));
  hvtest::setConstantTransferFunction(
    grid, static_cast<float>(1.0 - std::exp(-sigma)), albedo, 1.0f, 1.0f);

  hv::EnvironmentMap environment;
  const glm::vec3 L(0.7f, 1.1f, 2.0f);
  environment.setUniformRadiance(L);
  hv::SceneView scene;
  scene.volume = grid.view();
  scene.environment = environment.view();
  environment.sphericalHarmonics(scene.irradianceSH);
  scene.stepLength = 0.005f;
  scene.ambient = 0.3f;

  const hv::EyeView eye =
    makeEye(glm::lookAt(glm::vec3(0.0f, 0.0f, 3.0f), glm::vec3(0.0f), glm::vec3(0, 1, 0)),
      glm::ortho(-0.4f, 0.4f, -0.4f, 0.4f, 0.1f, 10.0f), 16, 16);
  const double opacity = 1.0 - std::exp(-sigma * 1.0);

  struct Case
  {
    const char* name;
    int model;
    bool environmentVisible;
    glm::vec3 expected; // radiance
  };
  const Case cases[] = {
    { "emission-absorption", hv::EmissionAbsorption, false, glm::vec3(albedo * float(opacity)) },
    // No lights: only the ambient term, ambient * albedo.
    { "gradient Phong, no lights", hv::GradientPhong, false,
      glm::vec3(scene.ambient * albedo * float(opacity)) },
    // A uniform environment gives irradiance pi L on surfaces and mean radiance L inside, so
    // both terms shade albedo * L; the visible environment adds L exp(-sigmaT d).
    { "prefiltered environment, visible", hv::PrefilteredEnvironment, true,
      glm::vec3(albedo * L * float(opacity) + L * float(1.0 - opacity)) },
  };
  for (const Case& c : cases)
  {
    scene.model = c.model;
    scene.environmentVisible = c.environmentVisible;
    RunningStats radiance[3], alpha;
    for (int y = 2; y < 14; ++y)
    {
      for (int x = 2; x < 14; ++x)
      {
        const hv::PixelResult p = hv::renderPixel(scene, eye, x, y, 0u, 0u, 5u, 4);
        for (int channel = 0; channel < 3; ++channel)
        {
          radiance[channel].add(p.radiance[channel]);
        }
        alpha.add(p.radiance.w);
        ASSERT_EQ(p.hit, 1);
        // The deterministic models report where the accumulated opacity crosses 1/2:
        // ln 2 / sigmaT into the box, which starts at z = 0.5.
        ASSERT_NEAR(p.firstScatterPosition.z, 0.5 - std::log(2.0) / sigma, 0.01) << c.name;
      }
    }
    std::printf("[ info ] %-34s radiance (%.4f, %.4f, %.4f), expected (%.4f, %.4f, %.4f), alpha "
                "%.4f (expected %.4f)\n",
      c.name, radiance[0].mean(), radiance[1].mean(), radiance[2].mean(), c.expected.x,
      c.expected.y, c.expected.z, alpha.mean(), c.environmentVisible ? 1.0 : opacity);
    for (int channel = 0; channel < 3; ++channel)
    {
      EXPECT_NEAR(radiance[channel].mean(), c.expected[channel], 0.02 * c.expected[channel])
        << c.name << " " << channel;
    }
    EXPECT_NEAR(alpha.mean(), c.environmentVisible ? 1.0 : opacity, 0.02 * opacity) << c.name;
  }
}

// The scalar a pixel reports is the data's at its first scatter point, whatever the transfer
// function shows: a ramp s = 0.1 + 0.8 x / 15 along the index x under a constant transfer
// function, which trilinear interpolation reproduces exactly (up to the 16-bit storage), so
// the reported scalar must equal the ramp at the reported point, for the path tracer's first
// collision and the ray-marched models' half-opacity depth alike.
TEST(Render, FirstScatterScalarIsTheDataAtTheFirstScatterPoint)
{
  const glm::ivec3 dims(16);
  hv::VolumeGrid grid;
  grid.setIndexToWorld(
    glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(-0.5f)), glm::vec3(1.0f / 15.0f)));
  grid.setScalars(
    dims, hvtest::sampleField(dims, [](const glm::vec3& p) { return 0.1f + 0.8f * p.x / 15.0f; }));
  hvtest::setConstantTransferFunction(grid, 0.5f, glm::vec3(0.8f), 0.1f, 1.0f);
  hv::EnvironmentMap environment;
  environment.setUniformRadiance(glm::vec3(1.0f));
  hv::SceneView scene = furnaceScene(grid, environment);
  scene.stepLength = 0.005f;
  // Looking along +x at the slab's side, so that first scatter points spread over the ramp.
  const hv::EyeView eye =
    makeEye(glm::lookAt(glm::vec3(-3.0f, 0.0f, 0.0f), glm::vec3(0.0f), glm::vec3(0, 1, 0)),
      glm::ortho(-0.4f, 0.4f, -0.4f, 0.4f, 0.1f, 10.0f), 16, 16);
  const glm::mat4 worldToIndex = glm::inverse(
    glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(-0.5f)), glm::vec3(1.0f / 15.0f)));
  for (int model : { hv::PathTraced, hv::PrefilteredEnvironment })
  {
    scene.model = model;
    RunningStats reported;
    int hits = 0;
    for (int y = 0; y < 16; ++y)
    {
      for (int x = 0; x < 16; ++x)
      {
        const hv::PixelResult p = hv::renderPixel(scene, eye, x, y, 0u, 0u, 9u, 2);
        if (!p.hit)
        {
          continue;
        }
        ++hits;
        const glm::vec3 index = glm::vec3(worldToIndex * glm::vec4(p.firstScatterPosition, 1.0f));
        ASSERT_NEAR(p.scalar, 0.1f + 0.8f * index.x / 15.0f, 1e-3f) << "model " << model;
        reported.add(p.scalar);
      }
    }
    EXPECT_EQ(hits, 256) << "model " << model;
    // The points lie at different depths along the ramp (each of the path tracer's is one
    // sample's free flight), not at one scalar.
    EXPECT_GT(std::sqrt(reported.variance()), model == hv::PathTraced ? 0.02 : 0.0);
    std::printf("[ info ] model %d: first scatter scalar %.4f +- %.4f\n", model, reported.mean(),
      std::sqrt(reported.variance()));
  }
}

// The path tracer without a visible environment returns radiance premultiplied by coverage,
// and a pixel that misses the volume returns exactly the environment when it is visible.
TEST(Render, PathTracerCoverage)
{
  hv::VolumeGrid grid;
  makeBall(grid, glm::vec3(1.0f));
  hv::EnvironmentMap environment;
  environment.setUniformRadiance(FurnaceRadiance);
  hv::SceneView scene = furnaceScene(grid, environment);
  const hv::EyeView eye =
    makeEye(glm::lookAt(glm::vec3(0.0f, 0.3f, 2.5f), glm::vec3(0.0f), glm::vec3(0, 1, 0)),
      glm::perspective(glm::radians(30.0f), 1.0f, 0.1f, 10.0f), 32, 32);
  // The corner pixel sees only the environment.
  hv::PixelResult corner = hv::renderPixel(scene, eye, 0, 0, 0u, 0u, 1u, 4);
  EXPECT_EQ(corner.hit, 0);
  EXPECT_FLOAT_EQ(corner.radiance.x, FurnaceRadiance.x);
  EXPECT_FLOAT_EQ(corner.radiance.w, 1.0f);
  scene.environmentVisible = false;
  corner = hv::renderPixel(scene, eye, 0, 0, 0u, 0u, 1u, 4);
  EXPECT_EQ(corner.radiance, glm::vec4(0.0f));
  const hv::PixelResult centre = hv::renderPixel(scene, eye, 16, 16, 0u, 0u, 1u, 16);
  EXPECT_EQ(centre.hit, 1);
  EXPECT_FLOAT_EQ(centre.radiance.w, 1.0f)
    << "every primary ray through the centre enters the ball";
}

// Next-event estimation towards a directional light: a slab (1 x 1 x 0.2, sigmaT = 2.5,
// albedo a) seen along -Z, lit through the same face from toLight at cos(theta) = mu, with
// maximumBounces = 1 and a black environment, has single-scattering radiance
//   L = a p pi I (1 - exp(-sigmaT d (1 + 1/mu))) / (1 + 1/mu),  p = HG(-mu, g)
// (the renderer treats a light of intensity I as irradiance pi I, see tracePath). Tolerance:
// 1 % and 5 standard errors over 64 pixel estimates of 12288 paths.
TEST(Render, SingleScatteringOfDirectionalLight)
{
  const glm::ivec3 dims(16, 16, 16);
  const float depth = 0.2f;
  const double sigma = 2.5;
  const glm::vec3 albedo(0.9f, 0.6f, 0.3f);
  hv::VolumeGrid grid;
  grid.setIndexToWorld(
    glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(-0.5f, -0.5f, -0.5f * depth)),
      glm::vec3(1.0f / 15.0f, 1.0f / 15.0f, depth / 15.0f)));
  grid.setScalars(dims, std::vector<float>(16 * 16 * 16, 1.0f));
  hvtest::setConstantTransferFunction(
    grid, static_cast<float>(1.0 - std::exp(-sigma)), albedo, 1.0f, 1.0f);
  hv::EnvironmentMap environment;
  environment.setUniformRadiance(glm::vec3(0.0f));

  const hv::EyeView eye =
    makeEye(glm::lookAt(glm::vec3(0.0f, 0.0f, 3.0f), glm::vec3(0.0f), glm::vec3(0, 1, 0)),
      glm::ortho(-0.2f, 0.2f, -0.2f, 0.2f, 0.1f, 10.0f), 8, 8);
  const double mu = 0.8;
  for (float g : { 0.0f, 0.5f })
  {
    hv::SceneView scene;
    scene.volume = grid.view();
    scene.environment = environment.view();
    scene.model = hv::PathTraced;
    scene.maximumBounces = 1;
    scene.anisotropy = g;
    scene.lightCount = 1;
    scene.lights[0].type = hv::DirectionalLight;
    scene.lights[0].toLight =
      glm::vec3(static_cast<float>(std::sqrt(1.0 - mu * mu)), 0.0f, static_cast<float>(mu));
    scene.lights[0].intensity = glm::vec3(2.0f);
    RunningStats radiance[3];
    for (int y = 0; y < 8; ++y)
    {
      for (int x = 0; x < 8; ++x)
      {
        const hv::PixelResult p = hv::renderPixel(scene, eye, x, y, 0u, 0u, 77u, 12288);
        for (int c = 0; c < 3; ++c)
        {
          radiance[c].add(p.radiance[c]);
        }
      }
    }
    const double phase = hv::henyeyGreenstein(static_cast<float>(-mu), g);
    const double k = 1.0 + 1.0 / mu;
    for (int c = 0; c < 3; ++c)
    {
      const double expected =
        albedo[c] * phase * hvtest::Pi * 2.0 * (1.0 - std::exp(-sigma * depth * k)) / k;
      if (c == 0)
      {
        std::printf(
          "[ info ] single scattering, g = %.1f: radiance %.5f +- %.5f, expected %.5f (%+.3f %%)\n",
          g, radiance[c].mean(), radiance[c].standardError(), expected,
          100.0 * (radiance[c].mean() - expected) / expected);
      }
      EXPECT_LT(5.0 * radiance[c].standardError(), 0.01 * expected)
        << "too few samples for a 1 % test";
      EXPECT_NEAR(radiance[c].mean(), expected, 0.01 * expected)
        << "g = " << g << ", channel " << c;
      EXPECT_NEAR(radiance[c].mean(), expected, 5.0 * radiance[c].standardError())
        << "g = " << g << ", channel " << c;
    }
  }
}

// Multiple importance sampling under a non-uniform environment: with environment importance
// sampling on and off (uniform light sampling), the MIS-weighted path tracer must converge to
// the same radiance. A wrong pdf in either MIS weight shows up as a difference. The pixels see
// different radiance, so the comparison is paired per pixel: the mean of the per-pixel
// differences must be within 5 of its standard errors of zero.
TEST(Render, EnvironmentImportanceSamplingIsUnbiasedInPathTracer)
{
  const int width = 32, height = 16;
  const std::vector<float> rgb = skyWithPatch(width, height, glm::ivec4(10, 3, 14, 6),
    glm::vec3(12.0f, 9.0f, 4.0f), glm::vec3(0.5f, 0.6f, 0.9f));
  hv::VolumeGrid grid;
  makeBall(grid, glm::vec3(0.8f, 0.8f, 0.8f));
  const hv::EyeView eye =
    makeEye(glm::lookAt(glm::vec3(0.0f, 0.3f, 2.5f), glm::vec3(0.0f), glm::vec3(0, 1, 0)),
      glm::perspective(glm::radians(30.0f), 1.0f, 0.1f, 10.0f), 32, 32);
  hv::EnvironmentMap environments[2];
  hv::SceneView scenes[2];
  for (int importance = 0; importance < 2; ++importance)
  {
    ASSERT_EQ(environments[importance].setRadiance(width, height, rgb), "");
    environments[importance].setWorldToMap(
      glm::mat3(glm::rotate(glm::mat4(1.0f), 0.4f, glm::vec3(0, 1, 0))));
    environments[importance].setImportanceSampling(importance == 1);
    scenes[importance] = furnaceScene(grid, environments[importance]);
    scenes[importance].maximumBounces = 4;
    scenes[importance].anisotropy = 0.3f;
  }
  RunningStats difference[3], radiance[2][3];
  for (int y = 10; y < 22; ++y)
  {
    for (int x = 10; x < 22; ++x)
    {
      hv::PixelResult p[2];
      for (int importance = 0; importance < 2; ++importance)
      {
        p[importance] = hv::renderPixel(
          scenes[importance], eye, x, y, 0u, static_cast<std::uint32_t>(importance), 99u, 1536);
        for (int c = 0; c < 3; ++c)
        {
          radiance[importance][c].add(p[importance].radiance[c]);
        }
      }
      for (int c = 0; c < 3; ++c)
      {
        difference[c].add(p[1].radiance[c] - p[0].radiance[c]);
      }
    }
  }
  for (int c = 0; c < 3; ++c)
  {
    const double mean = radiance[1][c].mean();
    if (c == 0)
    {
      std::printf(
        "[ info ] MIS: importance sampling %.4f, uniform light sampling %.4f, paired difference "
        "%+.5f +- %.5f (%+.2f %%)\n",
        mean, radiance[0][c].mean(), difference[c].mean(), difference[c].standardError(),
        100.0 * difference[c].mean() / mean);
    }
    EXPECT_NEAR(difference[c].mean(), 0.0, 5.0 * difference[c].standardError()) << "channel " << c;
    // The comparison must be sharp enough to matter: 5 SE below 4 % of the radiance (an MIS
    // weight error, e.g. a missing or doubled strategy, is a 10-50 % effect here).
    EXPECT_LT(5.0 * difference[c].standardError(), 0.04 * mean) << "channel " << c;
  }
}

// Russian roulette on secondary rays (shadow rays and the last phase/BRDF continuation) must
// not change the image, only its noise. Single scattering, as the mapper renders by default,
// under a map with a small bright patch plus a directional light, with hybrid surface events
// and forward scattering: roulette level 2 (far more aggressive than the default 0.5, so a
// bias would show) against no roulette, paired per pixel as in the MIS test above. The
// variance per path may grow, but by a bounded amount at the default level: each roulette
// adds at most (k L_mean throughput)^2 / 4 (measured here 1.2x at 0.5 and 4x at 2, with a
// patch 150x brighter than the sky; 1.02x at 0.5 on the head MRI of the benchmark).
TEST(Render, SecondaryRayRouletteIsUnbiased)
{
  const int width = 32, height = 16;
  const std::vector<float> rgb = skyWithPatch(width, height, glm::ivec4(12, 4, 14, 6),
    glm::vec3(60.0f, 50.0f, 30.0f), glm::vec3(0.3f, 0.4f, 0.7f));
  hv::VolumeGrid grid;
  makeBall(grid, glm::vec3(0.9f, 0.7f, 0.5f));
  grid.setSurfaceFactor(3.0f);
  hv::EnvironmentMap environment;
  ASSERT_EQ(environment.setRadiance(width, height, rgb), "");
  environment.setWorldToMap(glm::mat3(glm::rotate(glm::mat4(1.0f), 0.4f, glm::vec3(0, 1, 0))));
  hv::SceneView scene = furnaceScene(grid, environment);
  scene.maximumBounces = 1;
  scene.anisotropy = 0.3f;
  addDirectionalLight(scene);
  const hv::EyeView eye =
    makeEye(glm::lookAt(glm::vec3(0.0f, 0.3f, 2.5f), glm::vec3(0.0f), glm::vec3(0, 1, 0)),
      glm::perspective(glm::radians(30.0f), 1.0f, 0.1f, 10.0f), 32, 32);
  const float levels[3] = { 0.0f, 2.0f, 0.5f };
  RunningStats difference[3], radiance[3], perPath[3];
  for (int y = 10; y < 22; ++y)
  {
    for (int x = 10; x < 22; ++x)
    {
      hv::PixelResult p[3];
      for (int level = 0; level < 3; ++level)
      {
        scene.secondaryRayRoulette = levels[level];
        p[level] =
          hv::renderPixel(scene, eye, x, y, 0u, static_cast<std::uint32_t>(level), 7u, 4096);
        radiance[level].add(hv::luminance(glm::vec3(p[level].radiance)));
        // Single-path estimates of one pixel, for the variance per path.
        for (int frame = 0; frame < 64; ++frame)
        {
          const hv::PixelResult single = hv::renderPixel(
            scene, eye, x, y, 0u, static_cast<std::uint32_t>(100 + 64 * level + frame), 7u, 1);
          perPath[level].add(hv::luminance(glm::vec3(single.radiance)));
        }
      }
      for (int c = 0; c < 3; ++c)
      {
        difference[c].add(p[1].radiance[c] - p[0].radiance[c]);
      }
    }
  }
  std::printf("[ info ] roulette 0: %.4f, roulette 2: %.4f, roulette 0.5: %.4f; variance per path "
              "relative to no roulette: %.3f (level 2), %.3f (level 0.5)\n",
    radiance[0].mean(), radiance[1].mean(), radiance[2].mean(),
    perPath[1].variance() / perPath[0].variance(), perPath[2].variance() / perPath[0].variance());
  for (int c = 0; c < 3; ++c)
  {
    EXPECT_NEAR(difference[c].mean(), 0.0, 5.0 * difference[c].standardError()) << "channel " << c;
    EXPECT_LT(5.0 * difference[c].standardError(), 0.03 * radiance[0].mean()) << "channel " << c;
  }
  EXPECT_LT(perPath[2].variance(), 1.4 * perPath[0].variance());
}

// Stratified subpixel samples (SceneView::stratifiedSubpixelSamples) at a silhouette: a ball
// dense enough that its edge is sharp within a pixel (sigmaT = 1000 s per world unit, 43
// optical depths over one voxel of s = 1), so that a silhouette pixel's coverage noise is where
// its rays enter. Over the pixels whose converged coverage lies in (0.05, 0.95), 32 consecutive
// frames of 2 spp (as a history or a progressive sum holds them) estimate the coverage with an RMS
// error below 0.6 of independent uniform positions' (the same paths' random numbers
// otherwise), a single frame no worse, and the mean error within 5 standard errors of 0: the
// positions are stratified, not biased. The converged coverage is of 4096 uniform samples (its
// own RMS error, about 0.008, counts in both figures).
TEST(Render, StratifiedSubpixelSamplesResolveTheSilhouetteSooner)
{
  hv::VolumeGrid grid;
  makeBall(grid, glm::vec3(0.8f));
  grid.setTransferFunction(
    { 0.0f, 1.0f - std::exp(-1.0f) }, { 0.8f, 0.8f, 0.8f, 0.8f, 0.8f, 0.8f }, 0.001f, 1.0f);
  hv::EnvironmentMap environment;
  environment.setUniformRadiance(FurnaceRadiance);
  hv::SceneView scene = furnaceScene(grid, environment);
  scene.environmentVisible = false;
  scene.maximumBounces = 1;
  const hv::EyeView eye =
    makeEye(glm::lookAt(glm::vec3(0.0f, 0.3f, 2.5f), glm::vec3(0.0f), glm::vec3(0, 1, 0)),
      glm::perspective(glm::radians(30.0f), 1.0f, 0.1f, 10.0f), 32, 32);
  const int frames = 32, samplesPerPixel = 2;
  RunningStats stratifiedError;
  double squares[2] = { 0.0, 0.0 }, frameSquares[2] = { 0.0, 0.0 };
  int silhouettePixels = 0;
  for (int y = 0; y < eye.height; ++y)
  {
    for (int x = 0; x < eye.width; ++x)
    {
      // Only pixels whose centre ray passes within 1.5 pixels (0.063) of the ball's edge
      // (radius 9 voxels, 0.391, about the origin) can be partly covered.
      glm::vec3 origin, direction;
      float length;
      eye.generateRay(x + 0.5f, y + 0.5f, origin, direction, length);
      const float distance = glm::length(glm::cross(-origin, glm::normalize(direction)));
      if (std::abs(distance - 0.391f) > 0.063f)
      {
        continue;
      }
      scene.stratifiedSubpixelSamples = false;
      const float converged = hv::renderPixel(scene, eye, x, y, 0u, 1000u, 77u, 4096).radiance.w;
      if (!(converged > 0.05f && converged < 0.95f))
      {
        continue;
      }
      ++silhouettePixels;
      for (int stratified = 0; stratified < 2; ++stratified)
      {
        scene.stratifiedSubpixelSamples = stratified != 0;
        double sum = 0.0;
        for (int frame = 0; frame < frames; ++frame)
        {
          const float coverage = hv::renderPixel(
            scene, eye, x, y, 0u, static_cast<std::uint32_t>(40 + frame), 5u, samplesPerPixel)
                                   .radiance.w;
          sum += coverage;
          frameSquares[stratified] += (coverage - converged) * (coverage - converged);
        }
        const double error = sum / frames - converged;
        squares[stratified] += error * error;
        if (stratified)
        {
          stratifiedError.add(error);
        }
      }
    }
  }
  ASSERT_GT(silhouettePixels, 40);
  const double uniformRms = std::sqrt(squares[0] / silhouettePixels);
  const double stratifiedRms = std::sqrt(squares[1] / silhouettePixels);
  std::printf("[ info ] %d silhouette pixels; coverage RMS error over %d frames of %d spp: %.4f "
              "uniform, %.4f stratified (%.1fx); per frame %.4f and %.4f; mean error %.5f\n",
    silhouettePixels, frames, samplesPerPixel, uniformRms, stratifiedRms,
    uniformRms / stratifiedRms, std::sqrt(frameSquares[0] / (silhouettePixels * frames)),
    std::sqrt(frameSquares[1] / (silhouettePixels * frames)), stratifiedError.mean());
  EXPECT_LT(stratifiedRms, 0.6 * uniformRms);
  EXPECT_LT(frameSquares[1], 1.1 * frameSquares[0]);
  EXPECT_NEAR(stratifiedError.mean(), 0.0, 5.0 * stratifiedError.standardError());
}

namespace
{
// Renders the pixels around the ball's centre under `now` with `before` as the previous
// environment, and checks the estimate of the light under `before` against a render under it:
// unbiased (paired per pixel, as above), the current light's image the same as without it,
// and a change of light from the same paths whose
// variance is at most maximumVarianceRatio of that from two independent renders.
void checkPreviousLight(const char* label, const hv::SceneView& scene,
  const hv::EnvironmentMap& now, const hv::EnvironmentMap& before, const hv::EyeView& eye,
  double maximumVarianceRatio)
{
  hv::SceneView switched = scene;
  switched.environment = now.view();
  switched.previousEnvironment = before.view();
  switched.shadePreviousEnvironment = true;
  hv::SceneView old = scene;
  old.environment = before.view();
  hv::SceneView current = scene;
  current.environment = now.view();
  RunningStats bias[3], oldRadiance[3], correlated[3], independent[3];
  int changedByShading = 0;
  for (int y = 10; y < 22; ++y)
  {
    for (int x = 10; x < 22; ++x)
    {
      const hv::PixelResult shaded = hv::renderPixel(switched, eye, x, y, 0u, 1u, 99u, 1024);
      const hv::PixelResult reference = hv::renderPixel(old, eye, x, y, 0u, 2u, 99u, 1024);
      const hv::PixelResult alone = hv::renderPixel(current, eye, x, y, 0u, 1u, 99u, 1024);
      changedByShading += shaded.radiance == alone.radiance ? 0 : 1;
      for (int c = 0; c < 3; ++c)
      {
        bias[c].add(shaded.previousLightRadiance[c] - reference.radiance[c]);
        oldRadiance[c].add(reference.radiance[c]);
      }
      // 2-spp estimates of the change of light: from the same paths, and from two renders.
      for (std::uint32_t frame = 10; frame < 26; ++frame)
      {
        const hv::PixelResult a = hv::renderPixel(switched, eye, x, y, 0u, frame, 7u, 2);
        const hv::PixelResult b = hv::renderPixel(old, eye, x, y, 0u, frame + 100u, 7u, 2);
        for (int c = 0; c < 3; ++c)
        {
          correlated[c].add(a.radiance[c] - a.previousLightRadiance[c]);
          independent[c].add(a.radiance[c] - b.radiance[c]);
        }
      }
    }
  }
  for (int c = 0; c < 3; ++c)
  {
    const double mean = oldRadiance[c].mean();
    const double varianceRatio = correlated[c].variance() / independent[c].variance();
    if (c == 0)
    {
      std::printf("[ info ] %s: the previous light from the same paths %.4f against %.4f "
                  "rendered under it (paired difference %+.5f +- %.5f); variance of a 2-spp "
                  "change of light, same paths / independent renders: %.4f / %.4f (%.3f)\n",
        label, mean + bias[c].mean(), mean, bias[c].mean(), bias[c].standardError(),
        correlated[c].variance(), independent[c].variance(), varianceRatio);
    }
    EXPECT_NEAR(bias[c].mean(), 0.0, 5.0 * bias[c].standardError()) << label << ", channel " << c;
    EXPECT_LT(5.0 * bias[c].standardError(), 0.04 * mean) << label << ", channel " << c;
    // Both estimate the same change; only its noise differs.
    EXPECT_NEAR(correlated[c].mean(), independent[c].mean(),
      5.0 * (correlated[c].standardError() + independent[c].standardError()))
      << label << ", channel " << c;
    EXPECT_LT(varianceRatio, maximumVarianceRatio) << label << ", channel " << c;
  }
  EXPECT_EQ(changedByShading, 0) << label << ": the current light's image changed";
}
}

// The previous environment shaded with the same paths (SceneView::shadePreviousEnvironment):
// under an unchanged environment the two estimates are the same to the bit and the image is the
// one rendered without them; under a turned map, and a lamp switched on besides, the second
// estimate is unbiased for the old light and, sharing its paths with the first, differs from it
// less than an independent render does: that difference is what a denoiser relights its history
// with. A turn changes little of what each path sees, and most of the noise cancels; a lamp adds
// light of its own, whose noise stays.
TEST(Render, PreviousEnvironmentIsShadedWithTheSamePaths)
{
  const int width = 32, height = 16;
  const std::vector<float> room = skyWithPatch(width, height, glm::ivec4(10, 3, 14, 6),
    glm::vec3(6.0f, 5.0f, 3.0f), glm::vec3(0.5f, 0.6f, 0.9f));
  std::vector<float> lampOn = room;
  for (int row = 2; row < 4; ++row)
  {
    for (int column = 24; column < 26; ++column)
    {
      for (int c = 0; c < 3; ++c)
      {
        lampOn[3 * (static_cast<std::size_t>(row) * width + column) + c] += 80.0f;
      }
    }
  }
  hv::VolumeGrid grid;
  makeBall(grid, glm::vec3(0.9f, 0.7f, 0.5f));
  grid.setSurfaceFactor(3.0f);
  hv::EnvironmentMap before, turned, lamp;
  ASSERT_EQ(before.setRadiance(width, height, room), "");
  ASSERT_EQ(turned.setRadiance(width, height, room), "");
  ASSERT_EQ(lamp.setRadiance(width, height, lampOn), "");
  before.setWorldToMap(glm::mat3(glm::rotate(glm::mat4(1.0f), 0.4f, glm::vec3(0, 1, 0))));
  for (hv::EnvironmentMap* now : { &turned, &lamp })
  {
    now->setWorldToMap(glm::mat3(glm::rotate(glm::mat4(1.0f), 0.5f, glm::vec3(0, 1, 0))));
  }
  hv::SceneView scene = furnaceScene(grid, turned);
  scene.maximumBounces = 3;
  scene.anisotropy = 0.3f;
  addDirectionalLight(scene);
  const hv::EyeView eye =
    makeEye(glm::lookAt(glm::vec3(0.0f, 0.3f, 2.5f), glm::vec3(0.0f), glm::vec3(0, 1, 0)),
      glm::perspective(glm::radians(30.0f), 1.0f, 0.1f, 10.0f), 32, 32);

  // Unchanged: the same lookups under both, and the same random numbers as without them.
  hv::SceneView twice = scene;
  twice.previousEnvironment = scene.environment;
  twice.shadePreviousEnvironment = true;
  for (int y = 8; y < 24; ++y)
  {
    for (int x = 8; x < 24; ++x)
    {
      const hv::PixelResult once = hv::renderPixel(scene, eye, x, y, 0u, 5u, 17u, 2);
      const hv::PixelResult both = hv::renderPixel(twice, eye, x, y, 0u, 5u, 17u, 2);
      for (int c = 0; c < 3; ++c)
      {
        ASSERT_EQ(both.radiance[c], once.radiance[c]) << x << ", " << y;
        ASSERT_EQ(both.previousLightRadiance[c], both.radiance[c]) << x << ", " << y;
      }
      ASSERT_EQ(once.previousLightRadiance, glm::vec3(0.0f));
    }
  }
  checkPreviousLight("map turned", scene, turned, before, eye, 0.1);
  checkPreviousLight("map turned, lamp on", scene, lamp, before, eye, 0.8);
}
