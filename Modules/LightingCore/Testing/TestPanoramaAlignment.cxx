// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Spatial calibration: headset pose and camera mount rotate the panorama into the world, and
// the proxy-geometry warp re-centres it on the volume so that a lamp keeps its true direction.
#include "hv/lighting/PanoramaAlignment.h"

#include "hv/Equirectangular.h"

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <random>
#include <stdexcept>

namespace
{
// A Gaussian spot of angular width sigma around a direction, on a black panorama.
cv::Mat spotPanorama(int width, const glm::vec3& direction, float sigmaDegrees)
{
  cv::Mat panorama(width / 2, width, CV_32FC3);
  const glm::vec3 d = glm::normalize(direction);
  const float sigma = glm::radians(sigmaDegrees);
  for (int j = 0; j < panorama.rows; ++j)
  {
    for (int i = 0; i < panorama.cols; ++i)
    {
      const glm::vec3 w = hv::equirectangularToDirection(
        glm::vec2((i + 0.5f) / panorama.cols, (j + 0.5f) / panorama.rows));
      const float angle = std::acos(glm::clamp(glm::dot(w, d), -1.0f, 1.0f));
      const float value = std::exp(-0.5f * angle * angle / (sigma * sigma));
      panorama.at<cv::Vec3f>(j, i) = cv::Vec3f(value, 0.5f * value, 0.25f * value);
    }
  }
  return panorama;
}

// Solid-angle-weighted mean direction of the red channel.
glm::vec3 centroidDirection(const cv::Mat& panorama)
{
  glm::dvec3 sum(0.0);
  for (int j = 0; j < panorama.rows; ++j)
  {
    const double sinTheta = std::sin(hv::Pi * (j + 0.5) / panorama.rows);
    for (int i = 0; i < panorama.cols; ++i)
    {
      const glm::vec3 w = hv::equirectangularToDirection(
        glm::vec2((i + 0.5f) / panorama.cols, (j + 0.5f) / panorama.rows));
      sum += glm::dvec3(w) * double(panorama.at<cv::Vec3f>(j, i)[0]) * sinTheta;
    }
  }
  return glm::normalize(glm::vec3(sum));
}

float angleDegrees(const glm::vec3& a, const glm::vec3& b)
{
  return glm::degrees(
    std::acos(glm::clamp(glm::dot(glm::normalize(a), glm::normalize(b)), -1.0f, 1.0f)));
}

glm::mat4 pose(float yawDegrees, float pitchDegrees, const glm::vec3& position)
{
  glm::mat4 m = glm::translate(glm::mat4(1.0f), position);
  m = glm::rotate(m, glm::radians(yawDegrees), glm::vec3(0, 1, 0));
  return glm::rotate(m, glm::radians(pitchDegrees), glm::vec3(1, 0, 0));
}
}

TEST(PanoramaAlignment, FastAtan2MatchesStdAtan2)
{
  std::mt19937 engine(7);
  std::uniform_real_distribution<float> coordinate(-3.0f, 3.0f);
  float worst = 0.0f;
  for (int k = 0; k < 200000; ++k)
  {
    const float y = coordinate(engine);
    const float x = coordinate(engine);
    worst = std::max(worst, std::fabs(hv::lighting::fastAtan2(y, x) - std::atan2(y, x)));
  }
  // Axes and the origin, where a select picks the quadrant.
  for (float y : { -1.0f, 0.0f, 1.0f })
  {
    for (float x : { -1.0f, 0.0f, 1.0f })
    {
      if (x != 0.0f || y != 0.0f)
      {
        worst = std::max(worst, std::fabs(hv::lighting::fastAtan2(y, x) - std::atan2(y, x)));
      }
    }
  }
  EXPECT_EQ(hv::lighting::fastAtan2(0.0f, 0.0f), 0.0f);
  // 2e-5 rad is 0.0016 texel at 512 columns.
  EXPECT_LT(worst, 2e-5f) << "worst error " << worst << " rad";
}

TEST(PanoramaAlignment, IdentityPoseLeavesPanoramaUnchanged)
{
  hv::lighting::PanoramaAlignment alignment;
  alignment.setOutputSize(128, 64);
  alignment.update(glm::mat4(1.0f), glm::vec3(0.0f));
  cv::Mat panorama(64, 128, CV_32FC3);
  cv::randu(panorama, 0.0f, 1.0f);
  cv::Mat aligned;
  alignment.apply(panorama, aligned);
  ASSERT_EQ(aligned.size(), panorama.size());
  // Every output texel centre maps onto the same source texel centre (within fastAtan2's
  // accuracy), so bilinear resampling returns the texel itself.
  EXPECT_LT(cv::norm(aligned, panorama, cv::NORM_INF), 2e-3);
}

TEST(PanoramaAlignment, HeadsetRotationTurnsTheLightIntoWorldDirection)
{
  const glm::vec3 lightInCamera = glm::normalize(glm::vec3(0.3f, 0.6f, -0.7f));
  const cv::Mat cameraPanorama = spotPanorama(512, lightInCamera, 2.0f);
  // The camera is mounted on the headset looking backwards and tilted 10 degrees down.
  const glm::mat4 headsetFromCamera = pose(180.0f, -10.0f, glm::vec3(0.0f, 0.12f, 0.0f));
  const glm::mat4 worldFromHeadset = pose(75.0f, 20.0f, glm::vec3(0.0f));
  hv::lighting::PanoramaAlignment alignment;
  alignment.setCameraMount(headsetFromCamera);
  // A huge room makes the warp a pure rotation.
  alignment.setProxySphere(1e6f);
  alignment.update(worldFromHeadset, glm::vec3(0.0f));
  cv::Mat aligned;
  alignment.apply(cameraPanorama, aligned);
  const glm::vec3 expected = glm::mat3(worldFromHeadset * headsetFromCamera) * lightInCamera;
  EXPECT_LT(angleDegrees(centroidDirection(aligned), expected), 0.5f);
  EXPECT_LT(
    angleDegrees(alignment.volumeDirectionFromCameraDirection(lightInCamera), expected), 1e-3f);
}

TEST(PanoramaAlignment, SphereWarpRecentresLampOnVolume)
{
  // Camera 1.5 m beside the volume in a room of radius 3 m; a lamp on the proxy sphere.
  const glm::vec3 camera(1.5f, 0.2f, 0.0f);
  const glm::vec3 volume(0.0f, 0.0f, 0.0f);
  const float radius = 3.0f;
  const glm::vec3 lamp = camera + radius * glm::normalize(glm::vec3(-0.4f, 0.8f, -0.3f));
  const glm::mat4 worldFromHeadset = pose(30.0f, 0.0f, camera);
  const glm::vec3 lampInCamera =
    glm::transpose(glm::mat3(worldFromHeadset)) * glm::normalize(lamp - camera);
  const cv::Mat cameraPanorama = spotPanorama(512, lampInCamera, 1.5f);

  hv::lighting::PanoramaAlignment alignment;
  alignment.setProxySphere(radius);
  const auto& status = alignment.update(worldFromHeadset, volume);
  EXPECT_FALSE(status.ProxyAdjusted);
  cv::Mat aligned;
  alignment.apply(cameraPanorama, aligned);
  const glm::vec3 trueDirection = glm::normalize(lamp - volume);
  const glm::vec3 unwarpedDirection = glm::normalize(lamp - camera);
  // The lamp's direction from the volume differs from the camera's view by many degrees;
  // the warp must recover it. The spot is distorted by the re-projection, so its centroid is
  // compared with a tolerance of 1 degree.
  ASSERT_GT(angleDegrees(trueDirection, unwarpedDirection), 15.0f);
  EXPECT_LT(angleDegrees(centroidDirection(aligned), trueDirection), 1.0f);
  EXPECT_LT(
    angleDegrees(alignment.volumeDirectionFromCameraDirection(lampInCamera), trueDirection), 1e-3f);
  EXPECT_LT(
    angleDegrees(alignment.cameraDirectionFromVolumeDirection(trueDirection), lampInCamera), 1e-3f);
}

TEST(PanoramaAlignment, BoxWarpKeepsCeilingLampFixedAsUserWalks)
{
  // A 6 x 3 x 5 m room; a ceiling lamp; the volume on a table; the user walks around it.
  const glm::vec3 roomMin(-3.0f, 0.0f, -2.5f), roomMax(3.0f, 3.0f, 2.5f);
  const glm::vec3 lamp(1.0f, 3.0f, -1.0f);
  const glm::vec3 volume(0.0f, 1.0f, 0.0f);
  hv::lighting::PanoramaAlignment alignment;
  alignment.setOutputSize(512, 256);
  alignment.setProxyBox(roomMin, roomMax);
  for (const glm::vec3& user :
    { glm::vec3(0.0f, 1.7f, 1.2f), glm::vec3(-1.5f, 1.6f, 0.0f), glm::vec3(0.8f, 1.7f, -1.3f) })
  {
    const glm::mat4 worldFromHeadset = pose(glm::degrees(std::atan2(user.x, user.z)), -15.0f, user);
    const glm::vec3 lampInCamera =
      glm::transpose(glm::mat3(worldFromHeadset)) * glm::normalize(lamp - user);
    const cv::Mat cameraPanorama = spotPanorama(512, lampInCamera, 1.5f);
    alignment.update(worldFromHeadset, volume);
    cv::Mat aligned;
    alignment.apply(cameraPanorama, aligned);
    EXPECT_LT(angleDegrees(centroidDirection(aligned), lamp - volume), 1.0f)
      << "user at " << user.x << ", " << user.y << ", " << user.z;
  }
}

TEST(PanoramaAlignment, VolumeOutsideTheRoomIsHandled)
{
  hv::lighting::PanoramaAlignment alignment;
  alignment.setOutputSize(64, 32);
  alignment.setProxySphere(1.0f);
  const auto& status = alignment.update(glm::mat4(1.0f), glm::vec3(4.0f, 0.0f, 0.0f));
  EXPECT_TRUE(status.ProxyAdjusted);
  EXPECT_NEAR(status.EffectiveRadius, 4.0f / 0.9f, 1e-4f);
  cv::Mat panorama(32, 64, CV_32FC3, cv::Scalar(1.0f, 2.0f, 3.0f));
  cv::Mat aligned;
  alignment.apply(panorama, aligned);
  EXPECT_TRUE(cv::checkRange(aligned));
  EXPECT_LT(cv::norm(aligned, panorama, cv::NORM_INF), 1e-5);

  alignment.setProxyBox(glm::vec3(-1.0f), glm::vec3(1.0f));
  EXPECT_TRUE(alignment.update(glm::mat4(1.0f), glm::vec3(0.0f, 5.0f, 0.0f)).ProxyAdjusted);
  alignment.apply(panorama, aligned);
  EXPECT_TRUE(cv::checkRange(aligned));
}

TEST(PanoramaAlignment, BadInputIsRejected)
{
  hv::lighting::PanoramaAlignment alignment;
  EXPECT_THROW(alignment.setOutputSize(300, 100), std::invalid_argument);
  EXPECT_THROW(alignment.setProxySphere(0.0f), std::invalid_argument);
  EXPECT_THROW(alignment.setProxyBox(glm::vec3(1.0f), glm::vec3(-1.0f)), std::invalid_argument);
  cv::Mat panorama(32, 64, CV_32FC3, cv::Scalar::all(0.5));
  cv::Mat aligned;
  EXPECT_THROW(alignment.apply(panorama, aligned), std::logic_error);
  // A pose with scale is not a headset pose.
  EXPECT_THROW(alignment.update(glm::scale(glm::mat4(1.0f), glm::vec3(2.0f)), glm::vec3(0.0f)),
    std::invalid_argument);
  glm::mat4 nanPose(1.0f);
  nanPose[3][0] = std::nanf("");
  EXPECT_THROW(alignment.update(nanPose, glm::vec3(0.0f)), std::invalid_argument);
  alignment.update(glm::mat4(1.0f), glm::vec3(0.0f));
  EXPECT_THROW(alignment.apply(cv::Mat(30, 64, CV_32FC3), aligned), std::invalid_argument);
  EXPECT_THROW(alignment.apply(cv::Mat(32, 64, CV_32FC1), aligned), std::invalid_argument);
}

// After a new pose, apply() builds the remap tables a band of rows at a time and resamples each
// band while its tables are in the cache; a second apply() with the same pose resamples the whole
// panorama with one cv::remap over the complete tables. Both must give the same floats, for
// both proxies, in place too, and for an output size that differs from the input's.
TEST(PanoramaAlignment, BandedResamplingMatchesOneRemapOverTheWholeTables)
{
  cv::Mat panorama(128, 256, CV_32FC3);
  cv::randu(panorama, 0.0f, 1.0f);
  for (const bool box : { false, true })
  {
    hv::lighting::PanoramaAlignment alignment;
    alignment.setOutputSize(200, 100);
    if (box)
    {
      alignment.setProxyBox(glm::vec3(-3.0f, 0.0f, -2.5f), glm::vec3(3.5f, 2.8f, 3.0f));
    }
    alignment.update(
      pose(37.0f, -12.0f, glm::vec3(0.7f, 1.6f, -0.4f)), glm::vec3(0.2f, 1.0f, 0.3f));
    cv::Mat banded;
    alignment.apply(panorama, banded);
    cv::Mat whole;
    alignment.apply(panorama, whole); // the tables are complete now: one cv::remap
    ASSERT_EQ(banded.size(), cv::Size(200, 100));
    EXPECT_EQ(cv::norm(banded, whole, cv::NORM_INF), 0.0) << (box ? "box" : "sphere");
    // In place: the output replaces the input it is resampled from.
    alignment.update(
      pose(37.0f, -12.0f, glm::vec3(0.7f, 1.6f, -0.4f)), glm::vec3(0.2f, 1.0f, 0.3f));
    cv::Mat inPlace = panorama.clone();
    alignment.apply(inPlace, inPlace);
    EXPECT_EQ(cv::norm(inPlace, whole, cv::NORM_INF), 0.0) << (box ? "box" : "sphere");
  }
}
