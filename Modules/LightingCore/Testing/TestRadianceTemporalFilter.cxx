// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/CameraResponse.h"
#include "hv/lighting/IlluminationDifference.h"
#include "hv/lighting/RadianceTemporalFilter.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

using hv::lighting::CameraResponse;
using hv::lighting::IlluminationDifference;
using hv::lighting::RadianceTemporalFilter;

namespace
{
// A smooth room panorama (0.05..0.6 of the clip level) with a bright unclipped panel.
cv::Mat steadyScene(int width)
{
  const int height = width / 2;
  cv::Mat q(height, width, CV_32FC3);
  for (int y = 0; y < height; ++y)
  {
    for (int x = 0; x < width; ++x)
    {
      const float v = 0.05f +
        0.3f * (1.0f + std::cos(6.2831853f * x / width)) *
          (0.5f + 0.5f * static_cast<float>(height - y) / height);
      q.at<cv::Vec3f>(y, x) = cv::Vec3f(v, v * 0.95f, v * 0.9f);
    }
  }
  cv::rectangle(
    q, cv::Rect(width / 3, height / 5, width / 16, height / 16), cv::Scalar::all(0.85), cv::FILLED);
  return q;
}

cv::Mat capture(const cv::Mat& scene, std::mt19937& rng, double sigmaCodes)
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
}

TEST(RadianceTemporalFilter, BlendWeightFollowsTheIlluminationDifference)
{
  RadianceTemporalFilter filter;
  const auto& p = filter.parameters();
  EXPECT_FLOAT_EQ(filter.blendWeight(0.0f), p.MinBlend);
  EXPECT_FLOAT_EQ(filter.blendWeight(p.LowThreshold), p.MinBlend);
  EXPECT_FLOAT_EQ(filter.blendWeight(p.HighThreshold), 1.0f);
  EXPECT_FLOAT_EQ(filter.blendWeight(IlluminationDifference::MaxDifference), 1.0f);
  float previous = p.MinBlend;
  for (int i = 0; i <= 100; ++i) // monotone and continuous between the thresholds
  {
    const float a = filter.blendWeight(i / 100.0f);
    EXPECT_GE(a, previous);
    EXPECT_LT(a - previous, 0.1f);
    previous = a;
  }
}

// Sensor noise only (sigma = 2 code values): T stays small, so the filter averages, and the
// frame-to-frame variation of its output must be at least 3x smaller than that of its input.
TEST(RadianceTemporalFilter, NoiseOnlyFlickerIsReducedAtLeastThreeTimes)
{
  std::mt19937 rng(5);
  const cv::Mat scene = steadyScene(256);
  IlluminationDifference difference;
  RadianceTemporalFilter filter;
  cv::Mat previousIn;
  cv::Mat previousOut;
  double inputSq = 0.0;
  double outputSq = 0.0;
  float maxT = 0.0f;
  const int frames = 60;
  const int warmUp = 15; // about three time constants of the default MinBlend = 0.2
  for (int i = 0; i < frames; ++i)
  {
    const cv::Mat q = capture(scene, rng, 2.0);
    const float t = difference.update(q);
    if (i > 0)
    {
      maxT = std::max(maxT, t);
    }
    const cv::Mat out = filter.apply(q, t).clone();
    if (i > warmUp)
    {
      inputSq += std::pow(cv::norm(q, previousIn, cv::NORM_L2), 2.0);
      outputSq += std::pow(cv::norm(out, previousOut, cv::NORM_L2), 2.0);
    }
    previousIn = q;
    previousOut = out;
  }
  const double reduction = std::sqrt(inputSq / outputSq);
  std::printf("noise only: max T = %.4f, frame-to-frame RMS change reduced %.2fx (theory for "
              "a = 0.2: %.2fx)\n",
    maxT, reduction, std::sqrt(2.0 - 0.2) / 0.2);
  EXPECT_LT(maxT, filter.parameters().LowThreshold);
  EXPECT_GE(reduction, 3.0);
}

// A light switching on: T is large, so the output is the new map in that very frame.
TEST(RadianceTemporalFilter, LightSwitchPassesThroughWithinOneFrame)
{
  std::mt19937 rng(9);
  const cv::Mat scene = steadyScene(256);
  IlluminationDifference difference;
  RadianceTemporalFilter filter;
  for (int i = 0; i < 10; ++i)
  {
    const cv::Mat q = capture(scene, rng, 2.0);
    filter.apply(q, difference.update(q));
  }
  cv::Mat lit = capture(scene, rng, 2.0);
  cv::circle(lit, cv::Point(128, 40), 8, cv::Scalar::all(200.0), cv::FILLED); // the new lamp
  const float t = difference.update(lit);
  const cv::Mat& out = filter.apply(lit, t);
  std::printf("light switch: T = %.3f, blend weight %.3f, max |out - new Q| = %g\n", t,
    filter.lastBlendWeight(), cv::norm(out, lit, cv::NORM_INF));
  EXPECT_GE(t, filter.parameters().HighThreshold);
  EXPECT_EQ(cv::norm(out, lit, cv::NORM_INF), 0.0);
}

TEST(RadianceTemporalFilter, FirstFrameAndResetPassThrough)
{
  RadianceTemporalFilter filter;
  const cv::Mat a = steadyScene(128);
  const cv::Mat b = a * 2.0;
  EXPECT_FALSE(filter.hasHistory());
  EXPECT_EQ(cv::norm(filter.apply(a, 0.0f), a, cv::NORM_INF), 0.0);
  const cv::Mat blended = filter.apply(b, 0.0f).clone();
  cv::Mat expected;
  cv::addWeighted(b, 0.2, a, 0.8, 0.0, expected);
  EXPECT_LT(cv::norm(blended, expected, cv::NORM_INF), 1e-6);
  filter.reset();
  EXPECT_EQ(cv::norm(filter.apply(b, 0.0f), b, cv::NORM_INF), 0.0);
  cv::Mat copy;
  filter.apply(steadyScene(256), 0.0f, copy); // a size change restarts the history
  EXPECT_EQ(cv::norm(copy, steadyScene(256), cv::NORM_INF), 0.0);
}

TEST(RadianceTemporalFilter, BadInputGivesClearErrors)
{
  RadianceTemporalFilter filter;
  const cv::Mat good = steadyScene(128);
  EXPECT_THROW(filter.apply(cv::Mat(), 0.0f), std::invalid_argument);
  EXPECT_THROW(filter.apply(cv::Mat(64, 128, CV_8UC3), 0.0f), std::invalid_argument);
  EXPECT_THROW(
    filter.apply(cv::Mat(60, 128, CV_32FC3, cv::Scalar::all(0)), 0.0f), std::invalid_argument);
  EXPECT_THROW(filter.apply(good, std::nanf("")), std::invalid_argument);
  EXPECT_THROW(filter.apply(good, 1.5f), std::invalid_argument);
  cv::Mat withInf = good.clone();
  withInf.at<cv::Vec3f>(1, 1)[0] = INFINITY;
  EXPECT_THROW(filter.apply(withInf, 0.0f), std::invalid_argument);
  RadianceTemporalFilter::Parameters p;
  p.MinBlend = 0.0f;
  EXPECT_THROW(filter.setParameters(p), std::invalid_argument);
  p = RadianceTemporalFilter::Parameters();
  p.LowThreshold = 0.4f;
  p.HighThreshold = 0.3f;
  EXPECT_THROW(filter.setParameters(p), std::invalid_argument);
}

// The filter blends into a second buffer (no copy of the history, the NaN check in the same
// pass): the result equals Q_out = a Q + (1 - a) Q_out(t-1) as cv::addWeighted computes it, the
// map returned by one call is not written by the next, and a bad frame leaves the history as it
// was.
TEST(RadianceTemporalFilter, BlendInASecondBufferMatchesAddWeighted)
{
  RadianceTemporalFilter filter;
  cv::Mat a(64, 128, CV_32FC3), b(64, 128, CV_32FC3), c(64, 128, CV_32FC3);
  cv::RNG rng(5);
  rng.fill(a, cv::RNG::UNIFORM, 0.0, 2.0);
  rng.fill(b, cv::RNG::UNIFORM, 0.0, 2.0);
  rng.fill(c, cv::RNG::UNIFORM, 0.0, 2.0);
  const cv::Mat first = filter.apply(a, 0.0f); // a shallow copy, kept across the next call
  EXPECT_EQ(cv::norm(first, a, cv::NORM_INF), 0.0);
  const cv::Mat second = filter.apply(b, 0.1f);
  const float w = filter.blendWeight(0.1f);
  cv::Mat expected;
  cv::addWeighted(b, w, a, 1.0 - w, 0.0, expected);
  EXPECT_LT(cv::norm(second, expected, cv::NORM_INF), 1e-6);
  EXPECT_EQ(cv::norm(first, a, cv::NORM_INF), 0.0) << "the next call wrote the previous result";
  cv::Mat bad = c.clone();
  bad.at<cv::Vec3f>(10, 20)[1] = HUGE_VALF;
  EXPECT_THROW(filter.apply(bad, 0.1f), std::invalid_argument);
  const cv::Mat third = filter.apply(c, 0.1f); // blends into the history before the bad frame
  cv::addWeighted(c, w, expected, 1.0 - w, 0.0, expected);
  EXPECT_LT(cv::norm(third, expected, cv::NORM_INF), 1e-6);
  cv::Mat copy;
  filter.apply(a, 1.0f, copy);
  EXPECT_EQ(cv::norm(copy, a, cv::NORM_INF), 0.0);
}
