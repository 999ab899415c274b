// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// The simulated lens PSF keeps energy, spreads a point by the requested angle on the sphere
// (also near the poles) and leaves a uniform panorama unchanged.
#include "hv/lighting/LensGlare.h"

#include "hv/Equirectangular.h"
#include "hv/lighting/PanoramaMetrics.h"

#include <gtest/gtest.h>

#include <cmath>

namespace
{
// Solid-angle weighted sum of the first channel.
double flux(const cv::Mat& panorama)
{
  const cv::Mat weights = hv::lighting::sphericalWeights(panorama.size());
  cv::Mat channels[3];
  cv::split(panorama, channels);
  return channels[0].dot(weights);
}

// RMS angular distance of the first channel's energy from a direction, in degrees.
double angularSpread(const cv::Mat& panorama, const glm::vec3& centre)
{
  double sum = 0.0, weight = 0.0;
  for (int j = 0; j < panorama.rows; ++j)
  {
    const double sinTheta = std::sin(hv::Pi * (j + 0.5) / panorama.rows);
    for (int i = 0; i < panorama.cols; ++i)
    {
      const glm::vec3 w = hv::equirectangularToDirection(
        glm::vec2((i + 0.5f) / panorama.cols, (j + 0.5f) / panorama.rows));
      const double angle = hv::lighting::angleBetweenDegrees(w, centre);
      const double e = panorama.at<cv::Vec3f>(j, i)[0] * sinTheta;
      sum += e * angle * angle;
      weight += e;
    }
  }
  return std::sqrt(sum / weight);
}
}

TEST(LensGlare, KeepsEnergyAndSpreadsByTheRequestedAngle)
{
  for (const int row : { 128, 30 }) // equator, and 21 degrees from the zenith
  {
    cv::Mat point(256, 512, CV_32FC3, cv::Scalar::all(0.0));
    point.at<cv::Vec3f>(row, 200) = cv::Vec3f(1000.0f, 1000.0f, 1000.0f);
    const glm::vec3 centre =
      hv::equirectangularToDirection(glm::vec2(200.5f / 512.0f, (row + 0.5f) / 256.0f));
    cv::Mat filmed;
    hv::lighting::LensGlare glare;
    glare.HaloFraction = 0.0;
    glare.CoreSigmaDegrees = 4.0;
    hv::lighting::applyLensGlare(point, filmed, glare);
    EXPECT_NEAR(flux(filmed) / flux(point), 1.0, 0.02) << "row " << row;
    // A 2D Gaussian of sigma s has an RMS radius of s sqrt(2).
    EXPECT_NEAR(angularSpread(filmed, centre), 4.0 * std::sqrt(2.0), 0.6) << "row " << row;
  }
  const cv::Mat uniform(64, 128, CV_32FC3, cv::Scalar::all(0.7));
  cv::Mat filmed;
  hv::lighting::applyLensGlare(uniform, filmed, hv::lighting::LensGlare());
  EXPECT_LT(cv::norm(filmed, uniform, cv::NORM_INF), 1e-4);
  EXPECT_THROW(
    hv::lighting::applyLensGlare(cv::Mat(10, 10, CV_32FC3), filmed, {}), std::invalid_argument);
}
