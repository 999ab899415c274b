// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/CameraResponse.h"
#include "hv/lighting/IlluminationDifference.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

using hv::lighting::CameraResponse;
using hv::lighting::IlluminationDifference;
using hv::lighting::IlluminationDifferenceMode;

namespace
{
constexpr double Pi = 3.14159265358979323846;

// A dim room at width x width/2: smooth radiance between about 0.03 and 0.6 of the clip level
// (brighter ceiling, darker floor) times a fine texture (furniture, edges: blurred noise,
// log10 standard deviation about 0.2 in an SSIM window) drawn from `seed`.
cv::Mat roomPanorama(int width = 512, unsigned seed = 1)
{
  const int height = width / 2;
  cv::Mat texture(height, width, CV_32F);
  cv::RNG rng(seed);
  rng.fill(texture, cv::RNG::NORMAL, 0.0, 1.0);
  cv::GaussianBlur(texture, texture, cv::Size(0, 0), 1.0);
  cv::Mat q(height, width, CV_32FC3);
  for (int y = 0; y < height; ++y)
  {
    const double theta = (y + 0.5) * Pi / height;
    for (int x = 0; x < width; ++x)
    {
      const double phi = (x + 0.5) * 2.0 * Pi / width;
      const double base = 0.25 + 0.2 * std::cos(theta) + 0.08 * std::sin(3.0 * phi) +
        0.05 * std::sin(7.0 * phi + 2.0 * theta) + 0.03 * std::cos(13.0 * theta);
      const double v = std::max(0.03, base) * std::exp(1.65 * texture.at<float>(y, x));
      q.at<cv::Vec3f>(y, x) =
        cv::Vec3f(static_cast<float>(v * 1.05), static_cast<float>(v), static_cast<float>(v * 0.9));
    }
  }
  return q;
}

// Adds an area light (a latitude-longitude rectangle) of the given radiance.
void addPanel(
  cv::Mat& q, double phi0Deg, double phi1Deg, double theta0Deg, double theta1Deg, float radiance)
{
  const int width = q.cols;
  const int height = q.rows;
  for (int y = 0; y < height; ++y)
  {
    const double theta = (y + 0.5) * 180.0 / height;
    for (int x = 0; x < width; ++x)
    {
      const double phi = (x + 0.5) * 360.0 / width;
      if (theta >= theta0Deg && theta <= theta1Deg && phi >= phi0Deg && phi <= phi1Deg)
      {
        q.at<cv::Vec3f>(y, x) = cv::Vec3f(radiance, radiance, radiance);
      }
    }
  }
}

// The LDR path with sensor noise: 8-bit sRGB codes + Gaussian noise of sigma code values,
// re-quantised, then linearised.
cv::Mat noisyCapture(const cv::Mat& scene, double sigmaCodes, std::mt19937& rng)
{
  CameraResponse response;
  cv::Mat codes;
  response.encode(scene, codes);
  std::normal_distribution<double> noise(0.0, sigmaCodes);
  for (auto it = codes.begin<cv::Vec3b>(); it != codes.end<cv::Vec3b>(); ++it)
  {
    for (int c = 0; c < 3; ++c)
    {
      (*it)[c] = cv::saturate_cast<uchar>(std::lround((*it)[c] + noise(rng)));
    }
  }
  cv::Mat linear;
  response.linearize(codes, linear);
  return linear;
}

float differenceFor(const cv::Mat& before, const cv::Mat& after, IlluminationDifferenceMode mode)
{
  IlluminationDifference::Parameters p;
  p.Mode = mode;
  IlluminationDifference t(p);
  return t.compute(before, after);
}
}

TEST(IlluminationDifference, IdenticalFramesGiveZero)
{
  const cv::Mat q = roomPanorama();
  IlluminationDifference t;
  EXPECT_LT(t.compute(q, q), 1e-5f);
  ASSERT_EQ(t.patchSimilarity().rows, 8);
  ASSERT_EQ(t.patchSimilarity().cols, 8);
  double minSsim = 0.0;
  cv::minMaxLoc(t.patchSimilarity(), &minSsim);
  EXPECT_GT(minSsim, 1.0 - 1e-5);
}

// A ceiling panel (36 x 16 degrees, 100x the clip level, as the HDR estimation outputs it)
// switches on inside one patch of the 8 x 8 grid (patches are 45 x 22.5 degrees).
TEST(IlluminationDifference, OneLightSwitchingOnRaisesTOnlyUnderLeastSimilarPatch)
{
  const cv::Mat before = roomPanorama();
  cv::Mat after = before.clone();
  addPanel(after, 184.5, 220.5, 25.0, 41.0, 100.0f); // inside patch column 4, row 1
  IlluminationDifference::Parameters p;
  IlluminationDifference least(p);
  const float tLeast = least.compute(before, after);
  p.Mode = IlluminationDifferenceMode::MostSimilarPatch;
  IlluminationDifference most(p);
  const float tMost = most.compute(before, after);
  // Only the patch holding the panel changes.
  cv::Point worst;
  double minSsim = 0.0;
  cv::minMaxLoc(least.patchSimilarity(), &minSsim, nullptr, &worst);
  EXPECT_EQ(worst, cv::Point(4, 1));
  int changedPatches = 0;
  for (int r = 0; r < 8; ++r)
  {
    for (int c = 0; c < 8; ++c)
    {
      changedPatches += least.patchSimilarity().at<float>(r, c) < 0.99f ? 1 : 0;
    }
  }
  std::printf("one panel on: T(least similar) = %.3f, T(most similar, Eq. 1) = %.5f, patches "
              "with SSIM < 0.99: %d\n",
    tLeast, tMost, changedPatches);
  EXPECT_GT(tLeast, 0.5f);
  EXPECT_LT(tMost, 0.01f); // Eq. 1 as printed misses the change: why the text's variant is used
  EXPECT_LE(changedPatches, 2);
}

// The whole environment changes: the camera is carried into another room (same layout of
// brightness, other furniture) whose lights are dimmer. Both variants report a large T.
TEST(IlluminationDifference, GlobalChangeGivesLargeTInBothModes)
{
  const cv::Mat before = roomPanorama(512, 1);
  const cv::Mat after = roomPanorama(512, 2) * 0.5;
  const float tLeast = differenceFor(before, after, IlluminationDifferenceMode::LeastSimilarPatch);
  const float tMost = differenceFor(before, after, IlluminationDifferenceMode::MostSimilarPatch);
  std::printf("global change: T(least) = %.3f, T(most) = %.3f\n", tLeast, tMost);
  EXPECT_GT(tLeast, 0.5f);
  EXPECT_GT(tMost, 0.5f);
}

// Sensor noise (sigma = 1 and 2 code values on the 8-bit frame before linearisation) must not
// look like a lighting change.
TEST(IlluminationDifference, SensorNoiseKeepsTSmall)
{
  std::mt19937 rng(11);
  cv::Mat scene = roomPanorama();
  addPanel(scene, 184.5, 220.5, 25.0, 41.0, 0.9f); // a bright (unclipped) panel as well
  for (double sigma : { 1.0, 2.0 })
  {
    const cv::Mat a = noisyCapture(scene, sigma, rng);
    const cv::Mat b = noisyCapture(scene, sigma, rng);
    const float tLeast = differenceFor(a, b, IlluminationDifferenceMode::LeastSimilarPatch);
    const float tMost = differenceFor(a, b, IlluminationDifferenceMode::MostSimilarPatch);
    std::printf(
      "sensor noise sigma %.0f codes: T(least) = %.4f, T(most) = %.4f\n", sigma, tLeast, tMost);
    EXPECT_LT(tLeast, 0.05f);
    EXPECT_LT(tMost, 0.05f);
  }
}

TEST(IlluminationDifference, BlackFramesAndFirstFrameStayInRange)
{
  const cv::Mat black(128, 256, CV_32FC3, cv::Scalar::all(0.0));
  const cv::Mat bright = roomPanorama(256);
  IlluminationDifference t;
  const float tBlack = t.compute(black, black);
  EXPECT_GE(tBlack, 0.0f);
  EXPECT_LT(tBlack, 1e-6f);
  const float tOn = t.compute(black, bright * 1000.0);
  EXPECT_TRUE(std::isfinite(tOn));
  EXPECT_GT(tOn, 0.5f);
  EXPECT_LT(tOn, 1.0f);
  EXPECT_LE(tOn, IlluminationDifference::MaxDifference);
  EXPECT_TRUE(cv::checkRange(t.patchSimilarity()));

  // Streaming: the first frame has no history (T = MaxDifference < 1), then frame-to-frame.
  IlluminationDifference stream;
  EXPECT_FALSE(stream.hasHistory());
  EXPECT_FLOAT_EQ(stream.update(bright), IlluminationDifference::MaxDifference);
  EXPECT_LT(IlluminationDifference::MaxDifference, 1.0f);
  EXPECT_TRUE(stream.hasHistory());
  EXPECT_LT(stream.update(bright), 1e-5f);
  EXPECT_GT(stream.update(black), 0.5f);
  stream.reset();
  EXPECT_FLOAT_EQ(stream.update(black), IlluminationDifference::MaxDifference);
  // A size change invalidates the history as well.
  EXPECT_FLOAT_EQ(stream.update(roomPanorama(512)), IlluminationDifference::MaxDifference);
}

TEST(IlluminationDifference, PatchGridIsSettable)
{
  IlluminationDifference::Parameters p;
  p.PatchGrid = 4;
  IlluminationDifference t(p);
  const cv::Mat q = roomPanorama(256);
  t.compute(q, q);
  EXPECT_EQ(t.patchSimilarity().size(), cv::Size(4, 4));
}

TEST(IlluminationDifference, BadInputGivesClearErrors)
{
  IlluminationDifference t;
  const cv::Mat good = roomPanorama(256);
  EXPECT_THROW(t.compute(cv::Mat(), good), std::invalid_argument);
  EXPECT_THROW(t.compute(good, cv::Mat(128, 256, CV_8UC3)), std::invalid_argument);
  EXPECT_THROW(
    t.compute(good, cv::Mat(100, 256, CV_32FC3, cv::Scalar::all(1))), std::invalid_argument);
  EXPECT_THROW(t.compute(good, roomPanorama(512)), std::invalid_argument);
  cv::Mat withNan = good.clone();
  withNan.at<cv::Vec3f>(3, 4)[1] = std::nanf("");
  EXPECT_THROW(t.compute(good, withNan), std::invalid_argument);
  EXPECT_THROW(t.update(withNan), std::invalid_argument);
  IlluminationDifference::Parameters p;
  p.PatchGrid = 0;
  EXPECT_THROW(t.setParameters(p), std::invalid_argument);
  p = IlluminationDifference::Parameters();
  p.LuminanceFloor = 0.0f;
  EXPECT_THROW(t.setParameters(p), std::invalid_argument);
  p = IlluminationDifference::Parameters();
  p.MaxLuminance = p.LuminanceFloor;
  EXPECT_THROW(t.setParameters(p), std::invalid_argument);
  p = IlluminationDifference::Parameters();
  p.PatchGrid = 200;
  t.setParameters(p);
  EXPECT_THROW(t.compute(good, good), std::invalid_argument); // 128 rows < 200 patches
}

TEST(IlluminationDifference, SpeedOnOneCore)
{
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  const cv::Mat a = roomPanorama(512);
  cv::Mat b = a.clone();
  addPanel(b, 184.5, 220.5, 25.0, 41.0, 100.0f);
  IlluminationDifference t;
  t.update(a);
  double best = 1e9;
  for (int i = 0; i < 30; ++i)
  {
    const auto t0 = std::chrono::steady_clock::now();
    t.update(i % 2 ? a : b);
    const auto t1 = std::chrono::steady_clock::now();
    best = std::min(best, std::chrono::duration<double, std::milli>(t1 - t0).count());
  }
  std::printf("IlluminationDifference::update 512x256 on one core: %.3f ms (best of 30)\n", best);
  EXPECT_LT(best, 5.0); // the whole chain's budget; typical ~1 ms
  cv::setNumThreads(threads);
}

// The per-frame path computes l in natural logarithms and the SSIM window's moments with its
// own separable pass (in one sweep over the frame, for speed); this reference follows the
// definition literally (log10, cv::GaussianBlur 11 x 11 sigma 1.5 BORDER_REFLECT, Eq. 13,
// INTER_AREA patch means). The two must agree to float rounding.
TEST(IlluminationDifference, FastPathMatchesTheLiteralDefinition)
{
  const IlluminationDifference::Parameters p;
  auto logLuminance = [&p](const cv::Mat& q)
  {
    cv::Mat y;
    cv::transform(q, y, cv::Matx13f(0.2126f, 0.7152f, 0.0722f));
    cv::max(y, p.LuminanceFloor, y);
    y *= 1.0 / p.LuminanceFloor;
    cv::log(y, y);
    return cv::Mat(y * (1.0 / std::log(10.0)));
  };
  auto window = [](const cv::Mat& x)
  {
    cv::Mat blurred;
    cv::GaussianBlur(x, blurred, cv::Size(11, 11), 1.5, 1.5, cv::BORDER_REFLECT);
    return blurred;
  };
  cv::Mat previous = roomPanorama(512, 3);
  cv::Mat current = roomPanorama(512, 3);
  addPanel(current, 40.0, 70.0, 30.0, 50.0, 40.0f); // a lamp switches on in one place
  current *= 1.1;                                   // and everything brightens a little

  const cv::Mat x = logLuminance(previous);
  const cv::Mat y = logLuminance(current);
  const cv::Mat mx = window(x), my = window(y);
  const cv::Mat sxx = window(x.mul(x)), syy = window(y.mul(y)), sxy = window(x.mul(y));
  const double range = std::log10(p.MaxLuminance / p.LuminanceFloor);
  const double c1 = (0.01 * range) * (0.01 * range);
  const double c2 = (0.03 * range) * (0.03 * range);
  cv::Mat ssim(x.size(), CV_32F);
  for (int r = 0; r < x.rows; ++r)
  {
    for (int c = 0; c < x.cols; ++c)
    {
      const double a = mx.at<float>(r, c), b = my.at<float>(r, c);
      const double varX = std::max(sxx.at<float>(r, c) - a * a, 0.0);
      const double varY = std::max(syy.at<float>(r, c) - b * b, 0.0);
      const double cov = sxy.at<float>(r, c) - a * b;
      ssim.at<float>(r, c) = static_cast<float>(
        ((2.0 * a * b + c1) * (2.0 * cov + c2)) / ((a * a + b * b + c1) * (varX + varY + c2)));
    }
  }
  cv::Mat reference;
  cv::resize(ssim, reference, cv::Size(p.PatchGrid, p.PatchGrid), 0.0, 0.0, cv::INTER_AREA);

  IlluminationDifference difference(p);
  difference.update(previous);
  const float t = difference.update(current);
  const double worst = cv::norm(difference.patchSimilarity(), reference, cv::NORM_INF);
  double least = 0.0;
  cv::minMaxLoc(reference, &least);
  std::printf("fast path vs literal SSIM: worst patch difference %.2e, T %.6f vs %.6f\n", worst, t,
    1.0 - least);
  EXPECT_LT(worst, 1e-5);
  EXPECT_NEAR(t, 1.0 - least, 1e-5);
  EXPECT_GT(t, 0.3f); // the lamp's patch changed: the comparison is not between equal maps
  // compute() takes the same path.
  IlluminationDifference pair(p);
  EXPECT_NEAR(pair.compute(previous, current), t, 1e-6);
}
