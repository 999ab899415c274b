// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// The denoiser's per-pixel functions (hv/denoise/DenoiseKernels.h) run on a CUDA device and
// give what the CPU gives. Each test evaluates the same HV_FUNCTION code on the host and in a
// kernel and compares them within bounds that follow from the two compilers' arithmetic:
//  - nvcc contracts a product and a sum into one FMA (one rounding instead of two) where GCC for
//    x86-64 without FMA rounds both, so the same expression differs by a few units in the last
//    place (ulp);
//  - exponentialOfNegative is __expf on the device (2 + 1.173 x ulp, CUDA C Programming Guide,
//    "Intrinsic Functions") and a polynomial on the host (relative error below 4e-6); both
//    exponentiate an argument x that itself carries a few ulp, which e^-x turns into a relative
//    error of about x ulp.
// With the wavelet filter's cut-off at exponent 30 this bounds the weights' relative difference
// by 4e-6 + 37 ulp + 4 x 30 ulp (about 2.3e-5); the test allows 5e-5.
#include "DeviceTestSupport.h"
#include "hv/denoise/DenoiseKernels.h"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

using namespace hv::denoise;
using hvtest::DeviceBuffer;
using hvtest::RelativeDifference;

namespace
{
// One pixel's inputs to every per-pixel function: the surfaces two pixels see (a tap, the
// other eye's pixel or the history's), their luminances and coverages, T, and the history
// value with its neighbourhood statistics.
struct PixelCase
{
  Surface centre;
  Surface other;
  EdgeStopping edges;
  float centreLuminance = 0.0f;
  float otherLuminance = 0.0f;
  float luminanceScale = 0.0f;
  float coverage = 0.0f;
  float otherCoverage = 0.0f;
  float frames = 1.0f;
  float otherFrames = 1.0f;
  float coverageAgreementWidth = 1.0f;
  float illuminationDifference = 0.0f;
  float reprojectedDepth = 0.0f;
  float subpixel = 0.0f;
  float clampWidth = 1.0f;
  glm::vec4 radiance = glm::vec4(0.0f);
  glm::vec4 mean = glm::vec4(0.0f);
  glm::vec4 standardDeviation = glm::vec4(0.0f);
};

constexpr float DepthTolerance = 0.03f;
constexpr float NormalCosine = 0.5f;
constexpr float NormalGradient = 0.3f;

struct PixelWeights
{
  // Through exponentialOfNegative.
  float zeta;
  float waveletWeight;
  float waveletWeightWithCoverage;
  float lambda;
  float agreement;
  float crossCoverage;
  // Arithmetic and libm's expf only.
  glm::vec4 unpremultipliedBlend;
  float gate;
  float coverageSharpnessValue;
  float slack;
  float grazingArc;
  float catmullRom[4];
  glm::vec4 demodulated;
  glm::vec4 remodulated;
  glm::vec4 clamped;
  int consistent;
};

HV_FUNCTION PixelWeights evaluatePixel(const PixelCase& c)
{
  PixelWeights w;
  w.zeta = bilateralWeight(c.centre, c.other, c.edges);
  w.waveletWeight = waveletWeight(
    c.centre, c.other, c.centreLuminance, c.otherLuminance, c.luminanceScale, c.edges);
  const float coverageDifference = c.coverage - c.otherCoverage;
  w.coverageSharpnessValue = coverageSharpness(c.coverage, c.frames, c.coverageAgreementWidth);
  w.waveletWeightWithCoverage = waveletWeightOfChannels(c.centre.depth, c.centre.depthSpread,
    c.centre.gradientMagnitude, c.centre.normal, c.centre.albedo, c.centreLuminance,
    c.luminanceScale, c.other.depth, c.other.depthSpread, c.other.gradientMagnitude, c.other.normal,
    c.other.albedo, c.otherLuminance, inverseTwoSigmaSquared(c.edges.albedoSigma), c.edges,
    coverageDifference * coverageDifference * w.coverageSharpnessValue);
  w.lambda = stereoBlendWeight(c.centre.albedo, c.other.albedo, 0.5f, 2.0f);
  w.agreement = stereoAgreement(c.centreLuminance - c.otherLuminance,
    coverageVariance(c.coverage, c.frames) + coverageVariance(c.otherCoverage, c.otherFrames),
    3.0f);
  w.crossCoverage = crossViewCoverage(
    c.coverage, c.frames, c.otherCoverage, c.otherFrames, c.coverageAgreementWidth);
  // The radiance with this pixel's coverage against the neighbourhood mean with the other's,
  // with weights in [0, 1] taken from the case itself, not from an exp: the same on both sides.
  w.unpremultipliedBlend = stereoBlendUnpremultiplied(glm::vec4(glm::vec3(c.radiance), c.coverage),
    glm::vec4(glm::vec3(c.mean), c.otherCoverage), c.subpixel, c.otherCoverage);
  w.gate = temporalGate(c.illuminationDifference, 20.0f, -1.25f);
  w.slack = depthSlack(c.centre.depthSpread, c.centre.gradientMagnitude, c.other.depthSpread,
    c.other.gradientMagnitude);
  w.grazingArc = grazingHistoryArc(glm::dot(c.centre.normal, c.other.normal),
    c.centre.gradientMagnitude, 0.15f, 1.0f / 0.5f, 0.5f);
  catmullRomWeights(c.subpixel, w.catmullRom);
  w.demodulated = demodulate(c.radiance, c.centre.albedo);
  w.remodulated = remodulate(w.demodulated, c.centre.albedo);
  w.clamped = clampToNeighbourhood(c.radiance, c.mean, c.standardDeviation, c.clampWidth);
  w.consistent =
    consistentSurface(c.other, c.reprojectedDepth, c.centre.normal, c.centre.gradientMagnitude,
      c.centre.depthSpread, DepthTolerance, NormalCosine, NormalGradient)
    ? 1
    : 0;
  return w;
}

__global__ void evaluatePixelsKernel(const PixelCase* cases, int count, PixelWeights* weights)
{
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < count)
  {
    weights[i] = evaluatePixel(cases[i]);
  }
}

// Eq. 2's chain for one left-eye pixel: its first scatter point at a given view depth (the
// inverse projection), that point projected back into the left eye (it must land on the pixel's
// centre) and into the right eye (the stereo correspondence k_R^t).
struct Correspondence
{
  glm::vec2 leftPixel;
  glm::vec2 rightPixel;
  float rightDepth;
  int leftInside;
  int rightInside;
};

struct StereoPair
{
  glm::mat4 leftView, leftViewProjection, leftInverseViewProjection;
  glm::mat4 rightView, rightViewProjection;
  int width, height;
};

HV_FUNCTION float sceneDepth(int x, int y)
{
  // A smooth surface 0.8-1.2 units in front of the eye, so that every pixel has a point.
  return 1.0f +
    0.2f * glm::sin(0.01f * static_cast<float>(x)) * glm::cos(0.013f * static_cast<float>(y));
}

HV_FUNCTION Correspondence correspond(const StereoPair& pair, int x, int y)
{
  Correspondence c;
  glm::vec3 firstScatterPosition(0.0f);
  pointOnPixelRay(pair.leftInverseViewProjection, pair.leftView, x, y, pair.width, pair.height,
    sceneDepth(x, y), firstScatterPosition);
  float leftDepth;
  c.leftInside = projectToPixel(pair.leftViewProjection, pair.leftView, pair.width, pair.height,
                   firstScatterPosition, c.leftPixel, leftDepth)
    ? 1
    : 0;
  c.rightInside = projectToPixel(pair.rightViewProjection, pair.rightView, pair.width, pair.height,
                    firstScatterPosition, c.rightPixel, c.rightDepth)
    ? 1
    : 0;
  return c;
}

__global__ void correspondKernel(StereoPair pair, Correspondence* out)
{
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x < pair.width && y < pair.height)
  {
    out[y * pair.width + x] = correspond(pair, x, y);
  }
}

// The history fetched at a sub-pixel position with Catmull-Rom weights, the separable 4x4 fetch
// of the temporal stage, where all taps lie inside the image (0 elsewhere).
HV_FUNCTION glm::vec4 fetchHistory(
  const glm::vec4* history, int width, int height, const glm::vec2& position)
{
  const float fx = position.x - 0.5f;
  const float fy = position.y - 0.5f;
  const int x0 = static_cast<int>(floorf(fx));
  const int y0 = static_cast<int>(floorf(fy));
  glm::vec4 sum(0.0f);
  if (x0 >= 1 && y0 >= 1 && x0 + 2 < width && y0 + 2 < height)
  {
    float wx[4], wy[4];
    catmullRomWeights(fx - static_cast<float>(x0), wx);
    catmullRomWeights(fy - static_cast<float>(y0), wy);
    for (int j = 0; j < 4; ++j)
    {
      for (int k = 0; k < 4; ++k)
      {
        sum += (wx[k] * wy[j]) * history[(y0 - 1 + j) * width + (x0 - 1 + k)];
      }
    }
  }
  return sum;
}

__global__ void fetchHistoryKernel(const glm::vec4* history, int width, int height,
  const glm::vec2* positions, int count, glm::vec4* out)
{
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < count)
  {
    out[i] = fetchHistory(history, width, height, positions[i]);
  }
}

glm::vec3 randomUnitVector(std::mt19937& random)
{
  std::normal_distribution<float> normal(0.0f, 1.0f);
  glm::vec3 v(normal(random), normal(random), normal(random));
  return glm::normalize(v + glm::vec3(1e-6f));
}

// Cases spread over the functions' domains, half of them pairs of similar surfaces (a tap in the
// same structure, where the weights are far from 0) and half unrelated ones, with T, coverage and
// widths at their special values (T = 0, 1, NaN, out of range; coverage 0 and 1; width 0).
std::vector<PixelCase> makeCases(int count)
{
  std::mt19937 random(20261122u);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  const float specialT[] = { 0.0f, 1.0f, 1.0f - 1e-7f, 0.999f, -0.5f, 2.0f,
    std::numeric_limits<float>::quiet_NaN() };
  std::vector<PixelCase> cases(count);
  for (int i = 0; i < count; ++i)
  {
    PixelCase& c = cases[i];
    Surface& s = c.centre;
    s.depth = 0.5f + 2.5f * unit(random);
    s.normal = randomUnitVector(random);
    s.gradientMagnitude = unit(random);
    s.albedo = glm::vec3(unit(random), unit(random), unit(random));
    if (i % 17 == 0)
    {
      s.albedo.y = 0.0f; // a channel without albedo: demodulation keeps the radiance
    }
    s.depthSpread = 0.05f * unit(random);
    s.depthJitter = 0.02f * unit(random);
    s.normalJitter = 0.05f * unit(random);
    s.kind = static_cast<std::uint32_t>(i % 3);
    Surface& o = c.other;
    if (i % 2 == 0)
    {
      o = s;
      o.depth *= 1.0f + 0.01f * normal(random);
      o.normal = glm::normalize(s.normal + 0.2f * randomUnitVector(random));
      o.gradientMagnitude = glm::clamp(s.gradientMagnitude + 0.1f * normal(random), 0.0f, 1.0f);
      o.albedo = glm::clamp(
        s.albedo + 0.05f * glm::vec3(normal(random), normal(random), normal(random)), 0.0f, 1.0f);
    }
    else
    {
      o.depth = 0.5f + 2.5f * unit(random);
      o.normal = randomUnitVector(random);
      o.gradientMagnitude = unit(random);
      o.albedo = glm::vec3(unit(random), unit(random), unit(random));
      o.depthSpread = 0.05f * unit(random);
      o.depthJitter = 0.02f * unit(random);
      o.normalJitter = 0.05f * unit(random);
      o.kind = static_cast<std::uint32_t>((i / 2) % 3);
    }
    if (i % 5 == 0)
    {
      c.edges.albedoSigma = 0.02f + 0.3f * unit(random);
      c.edges.normalSharpness = 64.0f * unit(random);
      c.edges.depthSigma = 0.001f + 0.05f * unit(random);
    }
    c.centreLuminance = 2.0f * unit(random);
    c.otherLuminance =
      i % 2 == 0 ? c.centreLuminance * (1.0f + 0.2f * normal(random)) : 2.0f * unit(random);
    c.luminanceScale = 4.0f * unit(random);
    c.coverage = i % 11 == 0 ? 1.0f : (i % 13 == 0 ? 0.0f : unit(random));
    c.otherCoverage = glm::clamp(c.coverage + 0.2f * normal(random), 0.0f, 1.0f);
    c.frames = static_cast<float>(1 + i % 32);
    c.otherFrames = static_cast<float>(1 + (i / 7) % 32);
    c.coverageAgreementWidth = i % 23 == 0 ? 0.0f : 2.0f;
    c.illuminationDifference = i % 4 == 0 ? specialT[(i / 4) % 7] : unit(random);
    c.reprojectedDepth = o.depth * (1.0f + 0.05f * normal(random));
    c.subpixel = unit(random);
    c.clampWidth = (i % 3 == 0) ? 0.0f : 2.0f * unit(random);
    c.radiance =
      glm::vec4(2.0f * unit(random), 2.0f * unit(random), 2.0f * unit(random), unit(random));
    c.mean = glm::vec4(2.0f * unit(random), 2.0f * unit(random), 2.0f * unit(random), unit(random));
    c.standardDeviation =
      glm::vec4(0.3f * unit(random), 0.3f * unit(random), 0.3f * unit(random), 0.1f * unit(random));
  }
  return cases;
}

// How far a case lies from the disocclusion test's decision (relative to the depth, and in
// cosine): within a few ulp of it, host and device may decide differently by rounding alone.
float consistencyMargin(const PixelCase& c)
{
  const Surface& stored = c.other;
  const float slack = 2.0f *
      depthSlack(stored.depthSpread, stored.gradientMagnitude, c.centre.depthSpread,
        c.centre.gradientMagnitude) +
    stored.depthJitter;
  const float depthMargin = std::fabs(std::fabs(stored.depth - c.reprojectedDepth) -
                              (DepthTolerance * std::max(c.reprojectedDepth, 1e-6f) + slack)) /
    std::max(c.reprojectedDepth, 1e-6f);
  const float gradientMargin =
    std::fabs(std::min(stored.gradientMagnitude, c.centre.gradientMagnitude) - NormalGradient);
  const float normalMargin = std::fabs(
    glm::dot(stored.normal, c.centre.normal) - std::min(NormalCosine, 1.0f - stored.normalJitter));
  return std::min(depthMargin, std::min(gradientMargin, normalMargin));
}
}

TEST(DenoiseKernelsDevice, PerPixelFunctionsMatchTheHost)
{
  const int count = 1 << 18;
  const std::vector<PixelCase> cases = makeCases(count);
  DeviceBuffer<PixelCase> deviceCases(cases);
  DeviceBuffer<PixelWeights> deviceWeights(count);
  ASSERT_TRUE(deviceCases.get() && deviceWeights.get());
  evaluatePixelsKernel<<<(count + 255) / 256, 256>>>(deviceCases.get(), count, deviceWeights.get());
  HV_ASSERT_CUDA(cudaGetLastError());
  HV_ASSERT_CUDA(cudaDeviceSynchronize());
  const std::vector<PixelWeights> device = deviceWeights.download();

  RelativeDifference zeta(1e-12f), wavelet(1e-12f), lambda(1e-12f), agreement(1e-12f),
    crossCoverage(1e-12f), gate(1e-12f), arithmetic(0.0f);
  // Catmull-Rom weights (which sum to 1) and clamp bounds (mean - width sd) cancel: a rounding
  // of their O(1) terms is up to 4 ulp of 1 in the result, however small the result.
  RelativeDifference cancelling(5e-7f);
  int consistencyCompared = 0, consistencyMismatches = 0, nearDecision = 0;
  int positiveWeights = 0;
  for (int i = 0; i < count; ++i)
  {
    const PixelWeights host = evaluatePixel(cases[i]);
    const PixelWeights& d = device[i];
    zeta.add(host.zeta, d.zeta, i);
    wavelet.add(host.waveletWeight, d.waveletWeight, i);
    wavelet.add(host.waveletWeightWithCoverage, d.waveletWeightWithCoverage, i);
    lambda.add(host.lambda, d.lambda, i);
    agreement.add(host.agreement, d.agreement, i);
    crossCoverage.add(host.crossCoverage, d.crossCoverage, i);
    gate.add(host.gate, d.gate, i);
    arithmetic.add(host.coverageSharpnessValue, d.coverageSharpnessValue, i);
    arithmetic.add(host.slack, d.slack, i);
    arithmetic.add(host.grazingArc, d.grazingArc, i);
    for (int k = 0; k < 4; ++k)
    {
      cancelling.add(host.catmullRom[k], d.catmullRom[k], i);
      arithmetic.add(host.demodulated[k], d.demodulated[k], i);
      arithmetic.add(host.remodulated[k], d.remodulated[k], i);
      arithmetic.add(host.unpremultipliedBlend[k], d.unpremultipliedBlend[k], i);
      cancelling.add(host.clamped[k], d.clamped[k], i);
    }
    positiveWeights += host.waveletWeight > 1e-3f ? 1 : 0;
    if (consistencyMargin(cases[i]) > 1e-5f)
    {
      ++consistencyCompared;
      consistencyMismatches += host.consistent != d.consistent ? 1 : 0;
    }
    else
    {
      ++nearDecision;
    }
  }
  // The cases exercise the weights, not only their tails.
  EXPECT_GT(positiveWeights, count / 4);
  EXPECT_GT(consistencyCompared, count - count / 100);

  struct Row
  {
    const char* name;
    const RelativeDifference* difference;
    float bound;
  };
  const Row rows[] = { { "zeta (bilateral weight)", &zeta, 5e-5f },
    { "a-trous weight", &wavelet, 5e-5f }, { "D2 lambda", &lambda, 5e-5f },
    { "D2 agreement", &agreement, 5e-5f }, { "cross-view coverage", &crossCoverage, 5e-5f },
    // glm::exp is expf on both sides (at most 2 ulp on the device, CUDA C Programming Guide);
    // its argument, up to 80, carries the contraction's rounding.
    { "w_v sigmoid", &gate, 2e-5f },
    // Products, sums and divisions (correctly rounded on both sides): FMA contraction alone.
    { "demodulation, slack, grazing arc, coverage sharpness, D2's unpremultiplied blend",
      &arithmetic, 1e-5f },
    { "catmull-rom weights, neighbourhood clamp (beyond 5e-7)", &cancelling, 1e-5f } };
  for (const Row& row : rows)
  {
    std::printf("%-56s largest relative difference %.3g (bound %.0e)\n", row.name,
      row.difference->largest(), row.bound);
    EXPECT_LE(row.difference->largest(), row.bound) << row.name << ", " << row.difference->worst();
    EXPECT_EQ(row.difference->nanMismatches(), 0) << row.name;
  }
  std::printf("disocclusion test: %d of %d decisions differ (%d cases within 1e-5 of the "
              "threshold not compared)\n",
    consistencyMismatches, consistencyCompared, nearDecision);
  EXPECT_EQ(consistencyMismatches, 0);
}

// Eq. 2 on the device for every pixel of a 1440x936 eye: the first scatter point found by the
// inverse projection reprojects to the pixel's own centre in the left eye, and to the same
// right-eye position as on the host.
TEST(DenoiseKernelsDevice, StereoReprojectionMatchesTheHost)
{
  StereoPair pair;
  pair.width = 1440;
  pair.height = 936;
  const glm::mat4 projection = glm::perspective(
    glm::radians(52.0f), static_cast<float>(pair.width) / pair.height, 0.05f, 20.0f);
  // Eyes 64 mm apart looking at the origin from 1 m.
  pair.leftView =
    glm::lookAt(glm::vec3(-0.032f, 0.0f, 1.0f), glm::vec3(0.0f), glm::vec3(0.0f, 1.0f, 0.0f));
  pair.rightView =
    glm::lookAt(glm::vec3(0.032f, 0.0f, 1.0f), glm::vec3(0.0f), glm::vec3(0.0f, 1.0f, 0.0f));
  pair.leftViewProjection = projection * pair.leftView;
  pair.rightViewProjection = projection * pair.rightView;
  pair.leftInverseViewProjection = glm::inverse(pair.leftViewProjection);
  const int count = pair.width * pair.height;
  DeviceBuffer<Correspondence> deviceOut(count);
  ASSERT_TRUE(deviceOut.get());
  const dim3 block(16, 16);
  const dim3 grid((pair.width + 15) / 16, (pair.height + 15) / 16);
  correspondKernel<<<grid, block>>>(pair, deviceOut.get());
  HV_ASSERT_CUDA(cudaGetLastError());
  HV_ASSERT_CUDA(cudaDeviceSynchronize());
  const std::vector<Correspondence> device = deviceOut.download();

  float largestRoundTrip = 0.0f, largestHostDifference = 0.0f, largestDepthDifference = 0.0f;
  int rightInside = 0, insideMismatches = 0;
  for (int y = 0; y < pair.height; ++y)
  {
    for (int x = 0; x < pair.width; ++x)
    {
      const Correspondence& d = device[y * pair.width + x];
      const Correspondence host = correspond(pair, x, y);
      ASSERT_EQ(d.leftInside, 1) << x << ", " << y;
      largestRoundTrip =
        std::max(largestRoundTrip, glm::length(d.leftPixel - glm::vec2(x + 0.5f, y + 0.5f)));
      // Near the border a rounding may put the point on either side of it.
      const bool nearBorder = host.rightPixel.x < 0.01f || host.rightPixel.x > pair.width - 0.01f ||
        host.rightPixel.y < 0.01f || host.rightPixel.y > pair.height - 0.01f;
      if (!nearBorder && d.rightInside != host.rightInside)
      {
        ++insideMismatches;
        ADD_FAILURE() << "pixel " << x << ", " << y << ": right eye at " << host.rightPixel.x
                      << ", " << host.rightPixel.y << " is inside on the "
                      << (host.rightInside ? "host" : "device") << " only";
      }
      if (d.rightInside && host.rightInside)
      {
        ++rightInside;
        largestHostDifference =
          std::max(largestHostDifference, glm::length(d.rightPixel - host.rightPixel));
        largestDepthDifference = std::max(
          largestDepthDifference, std::fabs(d.rightDepth - host.rightDepth) / host.rightDepth);
      }
    }
  }
  std::printf("left round trip: largest error %.3g px; right eye: %d pixels inside, device and "
              "host %.3g px and %.3g (relative depth) apart at most\n",
    largestRoundTrip, rightInside, largestHostDifference, largestDepthDifference);
  // The float round trip through clip space at 1 m with a near plane of 5 cm.
  EXPECT_LT(largestRoundTrip, 0.02f);
  EXPECT_LT(largestHostDifference, 0.01f);
  EXPECT_LT(largestDepthDifference, 1e-5f);
  EXPECT_EQ(insideMismatches, 0);
  // The eyes' views overlap in most of the image.
  EXPECT_GT(rightInside, count * 9 / 10);
}

// The temporal stage's Catmull-Rom history fetch on the device: it reproduces a linear ramp at
// any sub-pixel position (the cubic's linear precision) and matches the host's fetch.
TEST(DenoiseKernelsDevice, CatmullRomFetchReproducesRampsAndMatchesTheHost)
{
  const int width = 257, height = 131;
  std::vector<glm::vec4> history(width * height);
  auto ramp = [](float x, float y)
  {
    return glm::vec4(
      0.1f + 0.01f * x, 0.5f + 0.004f * x - 0.003f * y, 2.0f - 0.01f * y, 0.25f + 0.001f * (x + y));
  };
  for (int y = 0; y < height; ++y)
  {
    for (int x = 0; x < width; ++x)
    {
      history[y * width + x] = ramp(x + 0.5f, y + 0.5f);
    }
  }
  std::mt19937 random(7u);
  std::uniform_real_distribution<float> column(0.0f, static_cast<float>(width));
  std::uniform_real_distribution<float> row(0.0f, static_cast<float>(height));
  const int count = 1 << 16;
  std::vector<glm::vec2> positions(count);
  for (glm::vec2& p : positions)
  {
    p = glm::vec2(column(random), row(random));
  }
  DeviceBuffer<glm::vec4> deviceHistory(history);
  DeviceBuffer<glm::vec2> devicePositions(positions);
  DeviceBuffer<glm::vec4> deviceOut(count);
  ASSERT_TRUE(deviceHistory.get() && devicePositions.get() && deviceOut.get());
  fetchHistoryKernel<<<(count + 255) / 256, 256>>>(
    deviceHistory.get(), width, height, devicePositions.get(), count, deviceOut.get());
  HV_ASSERT_CUDA(cudaGetLastError());
  HV_ASSERT_CUDA(cudaDeviceSynchronize());
  const std::vector<glm::vec4> device = deviceOut.download();

  RelativeDifference againstHost(0.0f), againstRamp(0.0f);
  int interior = 0;
  for (int i = 0; i < count; ++i)
  {
    const glm::vec4 host = fetchHistory(history.data(), width, height, positions[i]);
    const glm::vec4 expected = ramp(positions[i].x, positions[i].y);
    const bool inside = host != glm::vec4(0.0f);
    interior += inside ? 1 : 0;
    for (int k = 0; k < 4; ++k)
    {
      againstHost.add(host[k], device[i][k], i);
      if (inside)
      {
        againstRamp.add(expected[k], device[i][k], i);
      }
    }
  }
  std::printf("catmull-rom fetch: %d interior positions; device against host %.3g, against the "
              "ramp %.3g (largest relative differences)\n",
    interior, againstHost.largest(), againstRamp.largest());
  EXPECT_GT(interior, count * 9 / 10);
  EXPECT_LE(againstHost.largest(), 1e-5f) << againstHost.worst();
  EXPECT_LE(againstRamp.largest(), 1e-4f) << againstRamp.worst();
}

int main(int argc, char** argv)
{
  return hvtest::runDeviceTests(argc, argv);
}
