// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Random numbers (Random.h) and the sampling routines of Sampling.h.
//
// Statistical assertions use 5 standard errors: with fixed seeds the tests are deterministic,
// and a correct implementation exceeds 5 sigma with probability ~6e-7 for any seed, so a
// failure means a real bias, not bad luck.
#include "KernelTestUtilities.h"

#include "hv/Random.h"
#include "hv/Sampling.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <set>
#include <utility>
#include <vector>

namespace
{
using hvtest::RunningStats;

// Kolmogorov-Smirnov distance between sorted values mapped through their CDF and U(0, 1).
double ksDistance(std::vector<double> cdfValues)
{
  std::sort(cdfValues.begin(), cdfValues.end());
  const double n = static_cast<double>(cdfValues.size());
  double d = 0.0;
  for (std::size_t i = 0; i < cdfValues.size(); ++i)
  {
    d = std::max(d, std::max(cdfValues[i] - i / n, (i + 1) / n - cdfValues[i]));
  }
  return d;
}

// K-S critical value at significance 1e-4: sqrt(-ln(alpha / 2) / 2) / sqrt(n) = 2.23 / sqrt(n).
double ksCritical(std::size_t n)
{
  return 2.23 / std::sqrt(static_cast<double>(n));
}

std::vector<glm::vec3> testDirections()
{
  // Axes (both signs, the -Z case exercises makeBasis' other branch) and a few oblique ones.
  std::vector<glm::vec3> directions = { glm::vec3(0, 0, 1), glm::vec3(0, 0, -1), glm::vec3(1, 0, 0),
    glm::vec3(0, -1, 0), glm::normalize(glm::vec3(0.3f, -0.5f, 0.8f)),
    glm::normalize(glm::vec3(-0.2f, 0.1f, -0.97f)),
    glm::normalize(glm::vec3(1e-4f, 1e-4f, -1.0f)) };
  return directions;
}
}

// ---------------------------------------------------------------------------------------------
// Random numbers
// ---------------------------------------------------------------------------------------------

TEST(Random, Pcg32MatchesReferenceImplementation)
{
  // pcg32_srandom(42, 54) from O'Neill's pcg32-demo; its published first outputs.
  hv::Pcg32 rng;
  rng.state = 0u;
  rng.increment = (54u << 1u) | 1u;
  rng.nextUInt();
  rng.state += 42u;
  rng.nextUInt();
  const std::uint32_t expected[6] = { 0xa15c02b7u, 0x7b47f409u, 0xba1d3330u, 0x83d2f293u,
    0xbfa4784bu, 0xcbed606eu };
  for (std::uint32_t value : expected)
  {
    EXPECT_EQ(rng.nextUInt(), value);
  }
}

TEST(Random, SameTupleGivesSameStream)
{
  hv::Pcg32 a = hv::makePixelRng(1234u, 7u, 1u, 0xdeadbeefcafeULL);
  hv::Pcg32 b = hv::makePixelRng(1234u, 7u, 1u, 0xdeadbeefcafeULL);
  for (int i = 0; i < 1000; ++i)
  {
    ASSERT_EQ(a.nextUInt(), b.nextUInt()) << "at draw " << i;
  }
}

TEST(Random, DifferentTuplesGiveDifferentStreams)
{
  // Every (pixel, frame, eye, seed) tuple of a small grid must start a different stream: the
  // first two 32-bit outputs, as one 64-bit key, are all distinct (a collision among 4096
  // random 64-bit keys has probability ~5e-13).
  std::set<std::uint64_t> keys;
  int tuples = 0;
  for (std::uint32_t pixel = 0; pixel < 256; ++pixel)
  {
    for (std::uint32_t frame = 0; frame < 4; ++frame)
    {
      for (std::uint32_t eye = 0; eye < 2; ++eye)
      {
        for (std::uint64_t seed : { 0ULL, 1ULL })
        {
          hv::Pcg32 rng = hv::makePixelRng(pixel, frame, eye, seed);
          const std::uint64_t hi = rng.nextUInt();
          keys.insert((hi << 32) | rng.nextUInt());
          ++tuples;
        }
      }
    }
  }
  EXPECT_EQ(static_cast<int>(keys.size()), tuples);

  // Neighbouring pixels' streams are uncorrelated: |Pearson r| < 5 / sqrt(n).
  const int n = 100000;
  hv::Pcg32 a = hv::makePixelRng(0u, 0u, 0u, 5u);
  hv::Pcg32 b = hv::makePixelRng(1u, 0u, 0u, 5u);
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  for (int i = 0; i < n; ++i)
  {
    const double x = a.nextFloat(), y = b.nextFloat();
    sa += x;
    sb += y;
    saa += x * x;
    sbb += y * y;
    sab += x * y;
  }
  const double cov = sab / n - (sa / n) * (sb / n);
  const double r =
    cov / std::sqrt((saa / n - (sa / n) * (sa / n)) * (sbb / n - (sb / n) * (sb / n)));
  EXPECT_LT(std::abs(r), 5.0 / std::sqrt(static_cast<double>(n))) << "r = " << r;
}

TEST(Random, NextFloatIsUniformOnHalfOpenUnitInterval)
{
  hv::Pcg32 rng = hv::makePixelRng(42u, 3u, 0u, 99u);
  const int n = 1000000;
  const int bins = 16;
  std::vector<int> histogram(bins, 0);
  RunningStats stats;
  for (int i = 0; i < n; ++i)
  {
    const float u = rng.nextFloat();
    ASSERT_GE(u, 0.0f);
    ASSERT_LT(u, 1.0f);
    stats.add(u);
    ++histogram[static_cast<int>(u * bins)];
  }
  // Mean 1/2 within 5 standard errors of U(0,1) (sigma^2 = 1/12); variance 1/12 within 1 %
  // (its standard error is sqrt(1/180 / n) / (1/12) = 0.09 % relative).
  EXPECT_NEAR(stats.mean(), 0.5, 5.0 * std::sqrt(1.0 / 12.0 / n));
  EXPECT_NEAR(stats.variance(), 1.0 / 12.0, 0.01 / 12.0);
  // Chi-square with 15 degrees of freedom; 44.3 is its 1e-4 upper quantile.
  double chi2 = 0.0;
  const double expected = static_cast<double>(n) / bins;
  for (int count : histogram)
  {
    chi2 += (count - expected) * (count - expected) / expected;
  }
  EXPECT_LT(chi2, 44.3);

  // The largest value nextFloat can return (all 24 bits set) is still below one.
  EXPECT_LT(static_cast<float>(0xffffffu) * (1.0f / 16777216.0f), 1.0f);
}

// The subpixel sequence (SubpixelSequence): for any fixed sample index, the position over
// pixels is uniform on the pixel in both coordinates and the two are uncorrelated, so every
// sample on its own is distributed as an independent uniform one (nothing is biased).
TEST(SubpixelSequence, EachSampleIsUniformOverThePixel)
{
  const std::uint32_t pixels = 20000;
  for (std::uint32_t sampleIndex : { 0u, 1u, 7u, 123457u, 4000000000u })
  {
    std::vector<double> xs, ys;
    double sx = 0.0, sy = 0.0, sxx = 0.0, syy = 0.0, sxy = 0.0;
    for (std::uint32_t pixel = 0; pixel < pixels; ++pixel)
    {
      const glm::vec2 offset =
        hv::subpixelOffset(hv::makeSubpixelSequence(pixel, pixel % 2u, 5u), sampleIndex);
      ASSERT_GE(offset.x, 0.0f);
      ASSERT_LT(offset.x, 1.0f);
      ASSERT_GE(offset.y, 0.0f);
      ASSERT_LT(offset.y, 1.0f);
      xs.push_back(offset.x);
      ys.push_back(offset.y);
      sx += offset.x;
      sy += offset.y;
      sxx += offset.x * offset.x;
      syy += offset.y * offset.y;
      sxy += offset.x * offset.y;
    }
    EXPECT_LT(ksDistance(xs), ksCritical(pixels)) << "sample " << sampleIndex;
    EXPECT_LT(ksDistance(ys), ksCritical(pixels)) << "sample " << sampleIndex;
    const double n = pixels;
    const double r = (sxy / n - sx / n * sy / n) /
      std::sqrt((sxx / n - sx / n * sx / n) * (syy / n - sy / n * sy / n));
    EXPECT_LT(std::abs(r), 5.0 / std::sqrt(n)) << "sample " << sampleIndex;
  }
}

// The same pixel, eye and seed give the same sequence; another pixel, eye or seed another one.
TEST(SubpixelSequence, DependsOnPixelEyeAndSeedOnly)
{
  const hv::SubpixelSequence a = hv::makeSubpixelSequence(17u, 1u, 99u);
  const hv::SubpixelSequence b = hv::makeSubpixelSequence(17u, 1u, 99u);
  EXPECT_EQ(hv::subpixelOffset(a, 1000u), hv::subpixelOffset(b, 1000u));
  std::set<std::pair<std::uint32_t, std::uint32_t>> rotations;
  for (const hv::SubpixelSequence s : { a, hv::makeSubpixelSequence(18u, 1u, 99u),
         hv::makeSubpixelSequence(17u, 0u, 99u), hv::makeSubpixelSequence(17u, 1u, 100u) })
  {
    rotations.insert({ s.rotationX, s.rotationY });
  }
  EXPECT_EQ(rotations.size(), 4u);
}

// What the sequence is for: a pixel crossed by an edge. Its coverage (the area of the unit
// square on the edge's bright side) estimated from N consecutive samples, starting anywhere in
// the sequence as a denoiser's history or a progressive sum does, against N independent uniform
// samples. Over 4000 pixels (rotations) and edges at five angles and offsets: the stratified
// estimate's mean error is within 5 standard errors of 0 (unbiased); its RMS error is no worse
// than the uniform samples' at N = 2 (one frame; measured 1.0-1.2x better), below 0.6 of it at
// N = 64 (measured 2.0-3.2x better) and below 0.35 at N = 256 (3.7-6.0x); and from 64 to 256
// samples it falls by more than 2.5x, where 1/sqrt(N) would give 2x (measured 2.9-4.4x).
TEST(SubpixelSequence, ConsecutiveSamplesStratifyAnEdge)
{
  struct Edge
  {
    double angle;  // of the edge's normal, radians
    double offset; // signed distance of the edge from the pixel's centre
  };
  const Edge edges[] = { { 0.3, 0.0 }, { 1.1, 0.2 }, { 2.0, -0.3 }, { 0.785398, 0.05 },
    { 2.9, 0.41 } };
  const std::uint32_t pixels = 4000;
  for (const Edge& edge : edges)
  {
    const double nx = std::cos(edge.angle), ny = std::sin(edge.angle);
    auto bright = [&](double x, double y)
    { return (x - 0.5) * nx + (y - 0.5) * ny > edge.offset ? 1.0 : 0.0; };
    // The exact coverage, by the midpoint rule on a 2048 x 2048 grid (an error of ~1e-4 at
    // most for a straight edge, far below the estimates' errors).
    double coverage = 0.0;
    const int grid = 2048;
    for (int i = 0; i < grid; ++i)
    {
      for (int j = 0; j < grid; ++j)
      {
        coverage += bright((i + 0.5) / grid, (j + 0.5) / grid);
      }
    }
    coverage /= static_cast<double>(grid) * grid;
    double previousRms = 0.0;
    for (std::uint32_t count : { 2u, 64u, 256u })
    {
      RunningStats stratifiedError, uniformError;
      double stratifiedSquares = 0.0, uniformSquares = 0.0;
      for (std::uint32_t pixel = 0; pixel < pixels; ++pixel)
      {
        const hv::SubpixelSequence sequence = hv::makeSubpixelSequence(pixel, 0u, 31u);
        hv::Pcg32 rng = hv::makePixelRng(pixel, 0u, 0u, 31u);
        // Windows that start at different frames of a 2-spp sequence, far from 0 for some.
        const std::uint32_t first = 2u * (pixel * 7919u);
        double stratified = 0.0, uniform = 0.0;
        for (std::uint32_t k = 0; k < count; ++k)
        {
          const glm::vec2 offset = hv::subpixelOffset(sequence, first + k);
          stratified += bright(offset.x, offset.y);
          const double u = rng.nextFloat();
          uniform += bright(rng.nextFloat(), u);
        }
        const double e1 = stratified / count - coverage, e2 = uniform / count - coverage;
        stratifiedError.add(e1);
        uniformError.add(e2);
        stratifiedSquares += e1 * e1;
        uniformSquares += e2 * e2;
      }
      const double stratifiedRms = std::sqrt(stratifiedSquares / pixels);
      const double uniformRms = std::sqrt(uniformSquares / pixels);
      std::printf("edge at %.2f rad, offset %+.2f (coverage %.3f), %u samples: RMS error %.4f "
                  "stratified, %.4f uniform (%.1fx)\n",
        edge.angle, edge.offset, coverage, count, stratifiedRms, uniformRms,
        uniformRms / stratifiedRms);
      EXPECT_LT(std::abs(stratifiedError.mean()), 5.0 * stratifiedError.standardError() + 1e-4)
        << "angle " << edge.angle << ", " << count << " samples";
      const double bound = count == 2 ? 1.05 : count == 64 ? 0.6 : 0.35;
      EXPECT_LT(stratifiedRms, bound * uniformRms)
        << "angle " << edge.angle << ", " << count << " samples";
      if (count == 256)
      {
        EXPECT_LT(stratifiedRms, previousRms / 2.5) << "angle " << edge.angle;
      }
      previousRms = stratifiedRms;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Sampling
// ---------------------------------------------------------------------------------------------

TEST(Sampling, BasisIsOrthonormal)
{
  hv::Pcg32 rng = hv::makePixelRng(0u, 0u, 0u, 11u);
  std::vector<glm::vec3> normals = testDirections();
  for (int i = 0; i < 1000; ++i)
  {
    normals.push_back(hv::sampleUniformSphere(rng.nextFloat(), rng.nextFloat()));
  }
  for (const glm::vec3& n : normals)
  {
    glm::vec3 t, b;
    hv::makeBasis(n, t, b);
    EXPECT_NEAR(glm::length(t), 1.0f, 1e-5f);
    EXPECT_NEAR(glm::length(b), 1.0f, 1e-5f);
    EXPECT_NEAR(glm::dot(t, b), 0.0f, 1e-5f);
    EXPECT_NEAR(glm::dot(t, n), 0.0f, 1e-5f);
    EXPECT_NEAR(glm::dot(b, n), 0.0f, 1e-5f);
    // Right-handed, so fromLocal((0,0,1), n) = n.
    EXPECT_NEAR(glm::length(hv::fromLocal(glm::vec3(0, 0, 1), n) - n), 0.0f, 1e-5f);
  }
}

TEST(Sampling, UniformSphereIsUnitAndCentred)
{
  hv::Pcg32 rng = hv::makePixelRng(0u, 0u, 0u, 12u);
  const int n = 200000;
  RunningStats x, y, z, zz;
  for (int i = 0; i < n; ++i)
  {
    const glm::vec3 d = hv::sampleUniformSphere(rng.nextFloat(), rng.nextFloat());
    ASSERT_NEAR(glm::length(d), 1.0f, 1e-5f);
    x.add(d.x);
    y.add(d.y);
    z.add(d.z);
    zz.add(d.z * d.z);
  }
  // Each coordinate has mean 0 and variance 1/3; E[z^2] = 1/3 with variance 4/45.
  EXPECT_NEAR(x.mean(), 0.0, 5.0 * x.standardError());
  EXPECT_NEAR(y.mean(), 0.0, 5.0 * y.standardError());
  EXPECT_NEAR(z.mean(), 0.0, 5.0 * z.standardError());
  EXPECT_NEAR(zz.mean(), 1.0 / 3.0, 5.0 * zz.standardError());
}

TEST(Sampling, HenyeyGreensteinIntegratesToOne)
{
  for (float g : { -0.7f, 0.0f, 0.3f, 0.9f })
  {
    // The integral over the sphere is 2 pi int_{-1}^{1} p(mu) dmu. Composite Simpson in mu with
    // 2^16 intervals; the g = 0.9 peak at mu = 1 has width ~ (1 - g) = 0.1, i.e. thousands of
    // intervals, so the quadrature error is far below the float evaluation error (~1e-6).
    const int intervals = 1 << 16;
    const double h = 2.0 / intervals;
    double sum = 0.0;
    for (int i = 0; i <= intervals; ++i)
    {
      const double mu = -1.0 + i * h;
      const double weight = (i == 0 || i == intervals) ? 1.0 : (i % 2 == 1 ? 4.0 : 2.0);
      sum += weight * hv::henyeyGreenstein(static_cast<float>(mu), g);
    }
    const double integral = 2.0 * hvtest::Pi * sum * h / 3.0;
    EXPECT_NEAR(integral, 1.0, 1e-4) << "g = " << g;
  }
  // Isotropic case and forward peak value.
  EXPECT_NEAR(hv::henyeyGreenstein(0.3f, 0.0f), 1.0 / (4.0 * hvtest::Pi), 1e-7);
  EXPECT_NEAR(hv::henyeyGreenstein(1.0f, 0.5f), 0.75 / (4.0 * hvtest::Pi * 0.125), 1e-5);
  // g > 0 scatters forward.
  EXPECT_GT(hv::henyeyGreenstein(0.9f, 0.5f), hv::henyeyGreenstein(-0.9f, 0.5f));
}

TEST(Sampling, HenyeyGreensteinSamplesHaveMeanCosineG)
{
  hv::Pcg32 rng = hv::makePixelRng(0u, 0u, 0u, 13u);
  for (float g : { -0.7f, 0.0f, 0.3f, 0.9f })
  {
    for (const glm::vec3& incoming : testDirections())
    {
      const int n = 40000;
      RunningStats cosine;
      std::vector<double> cdf;
      cdf.reserve(n);
      for (int i = 0; i < n; ++i)
      {
        const glm::vec3 d =
          hv::sampleHenyeyGreenstein(incoming, g, rng.nextFloat(), rng.nextFloat());
        ASSERT_NEAR(glm::length(d), 1.0f, 1e-4f);
        const double mu = glm::dot(d, incoming);
        cosine.add(mu);
        // Analytic CDF of mu: (1 - g^2) / (2 g) [(1 + g^2 - 2 g mu)^(-1/2) - (1 + g)^(-1)].
        const double gd = g;
        cdf.push_back(std::abs(gd) < 1e-6 ? 0.5 * (mu + 1.0)
                                          : (1.0 - gd * gd) / (2.0 * gd) *
              (1.0 / std::sqrt(1.0 + gd * gd - 2.0 * gd * mu) - 1.0 / (1.0 + gd)));
      }
      // The mean cosine of HG is g (5 standard errors).
      EXPECT_NEAR(cosine.mean(), g, 5.0 * cosine.standardError()) << "g = " << g;
      // The whole distribution of mu matches (Kolmogorov-Smirnov at 1e-4 significance).
      EXPECT_LT(ksDistance(cdf), ksCritical(cdf.size())) << "g = " << g;
    }
  }
}

TEST(Sampling, CosineHemisphere)
{
  hv::Pcg32 rng = hv::makePixelRng(0u, 0u, 0u, 14u);
  for (const glm::vec3& n : testDirections())
  {
    glm::vec3 t, b;
    hv::makeBasis(n, t, b);
    RunningStats cosine, along, across;
    const int samples = 100000;
    for (int i = 0; i < samples; ++i)
    {
      const glm::vec3 d = hv::sampleCosineHemisphere(n, rng.nextFloat(), rng.nextFloat());
      ASSERT_NEAR(glm::length(d), 1.0f, 1e-4f);
      // On the normal's side (allowing float rounding at the horizon).
      ASSERT_GE(glm::dot(d, n), -1e-6f);
      cosine.add(glm::dot(d, n));
      along.add(glm::dot(d, t));
      across.add(glm::dot(d, b));
    }
    // pdf cos/pi gives E[cos] = 2/3 and no tangential bias.
    EXPECT_NEAR(cosine.mean(), 2.0 / 3.0, 5.0 * cosine.standardError());
    EXPECT_NEAR(along.mean(), 0.0, 5.0 * along.standardError());
    EXPECT_NEAR(across.mean(), 0.0, 5.0 * across.standardError());
  }
}

TEST(Sampling, PowerHeuristicWeightsSumToOne)
{
  hv::Pcg32 rng = hv::makePixelRng(0u, 0u, 0u, 15u);
  for (int i = 0; i < 10000; ++i)
  {
    const float a = std::exp(20.0f * rng.nextFloat() - 10.0f);
    const float b = std::exp(20.0f * rng.nextFloat() - 10.0f);
    const float wa = hv::powerHeuristic(a, b);
    const float wb = hv::powerHeuristic(b, a);
    ASSERT_GE(wa, 0.0f);
    ASSERT_LE(wa, 1.0f);
    ASSERT_NEAR(wa + wb, 1.0f, 1e-6f);
    ASSERT_NEAR(wa, a * a / (a * a + b * b), 1e-6f);
  }
  EXPECT_FLOAT_EQ(hv::powerHeuristic(2.0f, 0.0f), 1.0f);
  EXPECT_FLOAT_EQ(hv::powerHeuristic(0.0f, 2.0f), 0.0f);
  EXPECT_FLOAT_EQ(hv::powerHeuristic(0.0f, 0.0f), 0.0f);
  EXPECT_FLOAT_EQ(hv::powerHeuristic(1.0f, 1.0f), 0.5f);
}
