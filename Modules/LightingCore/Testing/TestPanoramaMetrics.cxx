// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// The measures the evaluation reports, checked against closed forms.
#include "hv/lighting/PanoramaMetrics.h"

#include "hv/Equirectangular.h"
#include "hv/Render.h"

#include <gtest/gtest.h>

#include <cmath>

namespace
{
cv::Mat diskPanorama(
  int width, const glm::vec3& direction, float radiusDegrees, float inside, float outside)
{
  cv::Mat panorama(width / 2, width, CV_32FC3);
  const float cosRadius = std::cos(glm::radians(radiusDegrees));
  for (int j = 0; j < panorama.rows; ++j)
  {
    for (int i = 0; i < panorama.cols; ++i)
    {
      const glm::vec3 w = hv::equirectangularToDirection(
        glm::vec2((i + 0.5f) / panorama.cols, (j + 0.5f) / panorama.rows));
      const float value = glm::dot(w, glm::normalize(direction)) >= cosRadius ? inside : outside;
      panorama.at<cv::Vec3f>(j, i) = cv::Vec3f::all(value);
    }
  }
  return panorama;
}
}

TEST(PanoramaMetrics, UniformRadianceGivesIrradiancePiL)
{
  const cv::Mat uniform(128, 256, CV_32FC3, cv::Scalar::all(2.0));
  const auto sh = hv::lighting::projectOnSphericalHarmonics(uniform);
  for (const glm::vec3& n :
    { glm::vec3(0, 1, 0), glm::vec3(1, 0, 0), glm::normalize(glm::vec3(1, -1, 2)) })
  {
    EXPECT_NEAR(hv::irradianceFromSH(sh.data(), n).y, 2.0f * hv::Pi, 0.01f * 2.0f * hv::Pi);
  }
  const cv::Mat half(128, 256, CV_32FC3, cv::Scalar::all(1.0));
  EXPECT_NEAR(hv::lighting::irradianceRelativeRmse(half, uniform), 0.5, 1e-3);
  EXPECT_NEAR(hv::lighting::irradianceRelativeRmse(uniform, uniform), 0.0, 1e-9);
}

TEST(PanoramaMetrics, PsnrAndSsimOfKnownDifferences)
{
  cv::Mat reference(64, 128, CV_32FC3);
  cv::randu(reference, 0.0f, 200.0f);
  EXPECT_TRUE(std::isinf(hv::lighting::weightedPsnr(reference, reference, 255.0)));
  EXPECT_NEAR(hv::lighting::weightedSsim(reference, reference, 255.0), 1.0, 1e-6);
  const cv::Mat offset = reference + cv::Scalar::all(2.0);
  // A constant error d everywhere: PSNR = 10 log10(peak^2 / d^2) whatever the weights.
  EXPECT_NEAR(hv::lighting::weightedPsnr(offset, reference, 255.0),
    10.0 * std::log10(255.0 * 255.0 / 4.0), 1e-3);
  cv::Mat noisy = reference.clone();
  cv::Mat noise(reference.size(), CV_32FC3);
  cv::randn(noise, 0.0, 20.0);
  noisy += noise;
  EXPECT_LT(hv::lighting::weightedSsim(noisy, reference, 255.0), 0.95);
  // The mask selects texels: an error confined to the masked-out half does not count.
  cv::Mat mask(reference.size(), CV_8U, cv::Scalar(0));
  mask.colRange(0, 64).setTo(255);
  cv::Mat halfBroken = reference.clone();
  halfBroken.colRange(64, 128) += cv::Scalar::all(50.0);
  EXPECT_TRUE(std::isinf(hv::lighting::weightedPsnr(halfBroken, reference, 255.0, mask)));
}

TEST(PanoramaMetrics, LogRmseOfAScaledMapIsTheLogOfTheScale)
{
  cv::Mat reference(64, 128, CV_32FC3);
  cv::randu(reference, 0.1f, 5.0f);
  EXPECT_NEAR(hv::lighting::logLuminanceRmse(reference * 10.0, reference), 1.0, 1e-4);
}

TEST(PanoramaMetrics, DominantLightOfADisk)
{
  for (const glm::vec3& direction :
    { glm::vec3(0.3f, 0.8f, -0.5f), glm::vec3(0.0f, 0.2f, 1.0f) /* across the u seam */ })
  {
    const cv::Mat panorama = diskPanorama(512, direction, 10.0f, 1000.0f, 0.5f);
    const auto light = hv::lighting::findDominantLight(panorama);
    ASSERT_TRUE(light.Found);
    EXPECT_LT(hv::lighting::angleBetweenDegrees(light.Direction, direction), 0.5);
    // A 10-degree disk subtends 2 pi (1 - cos 10deg) = 0.0954 sr.
    EXPECT_NEAR(light.SolidAngle, 0.0954, 0.01);
    EXPECT_GT(light.FluxFraction, 0.9);
  }
  // An overcast sky has no dominant light.
  const cv::Mat uniform(128, 256, CV_32FC3, cv::Scalar::all(1.0));
  EXPECT_FALSE(hv::lighting::findDominantLight(uniform).Found);
  const cv::Mat black(128, 256, CV_32FC3, cv::Scalar::all(0.0));
  EXPECT_FALSE(hv::lighting::findDominantLight(black).Found);
}

TEST(PanoramaMetrics, BadInputIsRejected)
{
  const cv::Mat a(64, 128, CV_32FC3, cv::Scalar::all(1.0));
  EXPECT_THROW(
    hv::lighting::weightedPsnr(a, cv::Mat(64, 100, CV_32FC3), 1.0), std::invalid_argument);
  EXPECT_THROW(
    hv::lighting::projectOnSphericalHarmonics(cv::Mat(64, 128, CV_32FC1)), std::invalid_argument);
  EXPECT_THROW(hv::lighting::weightedSsim(a, a, 1.0, cv::Mat(3, 3, CV_8U)), std::invalid_argument);
}
