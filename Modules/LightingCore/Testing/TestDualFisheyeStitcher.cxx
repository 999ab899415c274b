// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// DualFisheyeStitcher: round trip panorama -> renderDualFisheye -> stitch on synthetic
// panoramas, with exposure/white-balance mismatch and vignetting; a bright disk light lands
// at its direction; the saturation mask follows the clipped pixels; bad input throws; the
// single-core time per frame is reported.
#include "hv/lighting/DualFisheyeStitcher.h"
#include "hv/lighting/PanoramaMetrics.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <iostream>
#include <string>
#include <vector>

namespace
{
using hv::lighting::DualFisheyeStitcher;
using hv::lighting::FisheyeCalibration;
using hv::lighting::renderDualFisheye;
using hv::lighting::weightedPsnr;

constexpr double PiD = 3.14159265358979323846;
// See RoundTripOfASyntheticPanorama.
constexpr double MinimumPsnrAwayFromSeam = 60.0;
constexpr double MinimumPsnrInSeamBand = 55.0;

glm::dvec3 directionOfPixel(double x, double y, const cv::Size& size)
{
  const double phi = ((x + 0.5) / size.width - 0.5) * 2.0 * PiD;
  const double theta = (y + 0.5) / size.height * PiD;
  return glm::dvec3(
    std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi));
}

// A panorama of radiance(direction), averaged over supersampling^2 points per pixel.
cv::Mat makePanorama(const cv::Size& size,
  const std::function<cv::Vec3d(const glm::dvec3&)>& radiance, int supersampling)
{
  cv::Mat panorama(size, CV_32FC3);
  for (int y = 0; y < size.height; ++y)
  {
    for (int x = 0; x < size.width; ++x)
    {
      cv::Vec3d sum(0, 0, 0);
      for (int j = 0; j < supersampling; ++j)
      {
        for (int i = 0; i < supersampling; ++i)
        {
          sum += radiance(directionOfPixel(
            x + (i + 0.5) / supersampling - 0.5, y + (j + 0.5) / supersampling - 0.5, size));
        }
      }
      sum *= 1.0 / (supersampling * supersampling);
      panorama.at<cv::Vec3f>(y, x) = cv::Vec3f(
        static_cast<float>(sum[0]), static_cast<float>(sum[1]), static_cast<float>(sum[2]));
    }
  }
  return panorama;
}

double gaussianBlob(const glm::dvec3& d, const glm::dvec3& centre, double sigmaDegrees)
{
  const double angle = std::acos(std::clamp(glm::dot(d, glm::normalize(centre)), -1.0, 1.0));
  const double sigma = sigmaDegrees * PiD / 180.0;
  return std::exp(-0.5 * angle * angle / (sigma * sigma));
}

// Smooth colour gradients plus features of a few degrees: blobs on the seam (the plane z = 0,
// where the two 190-degree fields overlap), near the poles and inside each lens, and a
// longitudinal ripple. Values stay in [0, 1] (1 = full scale of the PSNR).
cv::Vec3d testScene(const glm::dvec3& d)
{
  const double ripple = 0.06 * std::sin(6.0 * std::atan2(d.x, -d.z)) * (1.0 - d.y * d.y);
  double r = 0.35 + 0.15 * d.x + 0.1 * d.y + ripple;
  double g = 0.30 + 0.12 * d.z - 0.08 * d.x * d.y + ripple;
  double b = 0.32 + 0.15 * d.y * d.z + 0.05 * d.x;
  const glm::dvec3 blobs[] = { { 1, 0.2, 0 }, { -1, -0.3, 0.05 }, { 0.3, 0.5, -1 },
    { -0.4, -0.2, 1 }, { 0.1, 1, 0.2 }, { 0.7, 0.1, 0.7 } };
  const double colours[][3] = { { 0.4, 0.1, 0.0 }, { 0.0, 0.35, 0.2 }, { 0.3, 0.3, 0.3 },
    { 0.1, 0.0, 0.4 }, { 0.2, 0.2, 0.0 }, { 0.0, 0.2, 0.4 } };
  for (int i = 0; i < 6; ++i)
  {
    const double w = gaussianBlob(d, blobs[i], 5.0);
    r += colours[i][0] * w;
    g += colours[i][1] * w;
    b += colours[i][2] * w;
  }
  return cv::Vec3d(r, g, b);
}

// A 190-degree equidistant test camera: 1024x512 frames, circles of radius 250 pixels.
FisheyeCalibration testCamera()
{
  FisheyeCalibration calibration;
  calibration.CameraName = "test";
  calibration.FrameWidth = 1024;
  calibration.FrameHeight = 512;
  for (auto* lens : { &calibration.Front, &calibration.Back })
  {
    lens->CenterX = 255.5;
    lens->CenterY = 255.5;
    lens->Radius = 250.0;
    lens->FieldOfViewDegrees = 190.0;
  }
  calibration.Stitching.BlendBandDegrees = 8.0;
  calibration.Stitching.AutomaticGainMatching = true;
  return calibration;
}

struct RoundTrip
{
  double AwayFromSeam = 0.0;
  double InSeamBand = 0.0;
  std::array<double, 3> Gain{};
};

RoundTrip roundTrip(const cv::Mat& panorama, const FisheyeCalibration& cameraTruth,
  const FisheyeCalibration& stitchCalibration, const cv::Size& frameSize)
{
  const cv::Mat frame = renderDualFisheye(panorama, cameraTruth, frameSize);
  DualFisheyeStitcher stitcher;
  stitcher.configure(stitchCalibration, frameSize, panorama.size());
  cv::Mat stitched;
  stitcher.stitch(frame, stitched);
  const cv::Mat band = stitcher.overlapMask();
  cv::Mat away;
  cv::bitwise_not(band, away);
  RoundTrip result;
  result.AwayFromSeam = weightedPsnr(stitched, panorama, 1.0, away);
  result.InSeamBand = weightedPsnr(stitched, panorama, 1.0, band);
  result.Gain = stitcher.backToFrontGain();
  return result;
}
}

// The panorama comes back away from the seam (solid-angle weighted PSNR, full scale 1) and in
// the 10-degree overlap band, where both lenses are blended. The issue asks for >= 40 dB away
// from the seam; the smooth test scene comes back at about 77 dB away and 73 dB in the band
// (69/64 dB from a 384x192 frame), so the thresholds used here, 60 and 55 dB, also catch a
// misregistration of a fraction of a pixel, which costs the 5-degree blobs far more.
TEST(DualFisheyeStitcher, RoundTripOfASyntheticPanorama)
{
  const cv::Mat panorama = makePanorama(cv::Size(256, 128), testScene, 4);
  const FisheyeCalibration camera = testCamera();
  const RoundTrip result = roundTrip(panorama, camera, camera, cv::Size(1024, 512));
  std::cout << "round trip 256x128 from 1024x512, 190 deg: PSNR away from seam "
            << result.AwayFromSeam << " dB, in seam band " << result.InSeamBand << " dB\n";
  EXPECT_GE(result.AwayFromSeam, MinimumPsnrAwayFromSeam);
  EXPECT_GE(result.InSeamBand, MinimumPsnrInSeamBand);
  // Equal lenses: the estimated back/front gain is 1 within 0.5 %.
  for (double g : result.Gain)
  {
    EXPECT_NEAR(g, 1.0, 0.005);
  }
}

// Without pre-reduction (a frame at about the panorama's resolution) and with a frame 7x
// finer (halved with INTER_AREA inside the stitcher) the round trip holds too.
TEST(DualFisheyeStitcher, RoundTripAtOtherFrameSizes)
{
  const cv::Mat panorama = makePanorama(cv::Size(256, 128), testScene, 4);
  const FisheyeCalibration camera = testCamera();
  for (const cv::Size frameSize : { cv::Size(384, 192), cv::Size(2048, 1024) })
  {
    DualFisheyeStitcher probe;
    probe.configure(camera, frameSize, panorama.size());
    const RoundTrip result = roundTrip(panorama, camera, camera, frameSize);
    std::cout << "round trip from " << frameSize.width << "x" << frameSize.height << " (reduction "
              << probe.reductionFactor() << "): away " << result.AwayFromSeam << " dB, band "
              << result.InSeamBand << " dB\n";
    EXPECT_GE(result.AwayFromSeam, MinimumPsnrAwayFromSeam);
    EXPECT_GE(result.InSeamBand, MinimumPsnrInSeamBand);
  }
}

// Equisolid and Kannala-Brandt lenses of different fields of view, a back lens turned by a
// few degrees about all three axes and different vignetting per lens: the same round-trip
// quality. Stitching with the rotation left out costs over 30 dB (measured 40 dB: the smooth
// scene forgives a 3-degree error more than the 60 dB threshold does).
TEST(DualFisheyeStitcher, RoundTripWithOtherModelsAndATurnedBackLens)
{
  const cv::Mat panorama = makePanorama(cv::Size(256, 128), testScene, 4);
  FisheyeCalibration camera = testCamera();
  camera.Front.Model = hv::FisheyeProjection::Equisolid;
  camera.Front.FieldOfViewDegrees = 195.0;
  camera.Front.Vignetting = { { -0.2, 0.0, -0.05 } };
  camera.Back.Model = hv::FisheyeProjection::KannalaBrandt;
  camera.Back.FieldOfViewDegrees = 200.0;
  camera.Back.KannalaBrandt = { { 0.03, -0.012, 0.002, -0.0002 } };
  camera.Back.CenterX = 252.0;
  camera.Back.CenterY = 258.5;
  camera.Back.YawDegrees = 2.0;
  camera.Back.PitchDegrees = -1.5;
  camera.Back.RollDegrees = 3.0;
  const RoundTrip result = roundTrip(panorama, camera, camera, cv::Size(1024, 512));
  FisheyeCalibration unturned = camera;
  unturned.Back.YawDegrees = unturned.Back.PitchDegrees = unturned.Back.RollDegrees = 0.0;
  const RoundTrip wrong = roundTrip(panorama, camera, unturned, cv::Size(1024, 512));
  std::cout << "equisolid 195 + Kannala-Brandt 200, back lens turned: PSNR away "
            << result.AwayFromSeam << " dB, band " << result.InSeamBand
            << " dB; rotation ignored: away " << wrong.AwayFromSeam << " dB\n";
  EXPECT_GE(result.AwayFromSeam, MinimumPsnrAwayFromSeam);
  EXPECT_GE(result.InSeamBand, MinimumPsnrInSeamBand);
  EXPECT_LT(wrong.AwayFromSeam, 50.0);
}

namespace
{
// The sRGB EOTF as a 256-entry camera response, and a linear frame encoded with its inverse.
cv::Mat srgbResponse()
{
  cv::Mat response(1, 256, CV_32FC1);
  for (int i = 0; i < 256; ++i)
  {
    const double v = i / 255.0;
    response.at<float>(i) =
      static_cast<float>(v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4));
  }
  return response;
}

cv::Mat encodeSrgb(const cv::Mat& linear)
{
  cv::Mat encoded(linear.size(), CV_8UC3);
  for (int y = 0; y < linear.rows; ++y)
  {
    for (int x = 0; x < linear.cols; ++x)
    {
      for (int c = 0; c < 3; ++c)
      {
        const double v = std::clamp(static_cast<double>(linear.at<cv::Vec3f>(y, x)[c]), 0.0, 1.0);
        const double e = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
        encoded.at<cv::Vec3b>(y, x)[c] = static_cast<std::uint8_t>(std::lround(255.0 * e));
      }
    }
  }
  return encoded;
}
}

// stitchEncoded() (interpolating 8-bit codes, linearising the samples) against stitch() of the
// linearised frame: both >= 50 dB from the panorama (measured 59.5 and 57.1 dB: the 8-bit
// quantisation of the frame, and for stitchEncoded the rounding of the interpolated codes to
// 8 bits again), within 3 dB of each other.
TEST(DualFisheyeStitcher, EncodedFastPathMatchesTheLinearPath)
{
  const cv::Mat panorama = makePanorama(cv::Size(256, 128), testScene, 4);
  const FisheyeCalibration camera = testCamera();
  const cv::Mat encoded = encodeSrgb(renderDualFisheye(panorama, camera, cv::Size(1024, 512)));
  const cv::Mat response = srgbResponse();
  cv::Mat linear;
  cv::LUT(encoded, response, linear);
  DualFisheyeStitcher stitcher;
  stitcher.configure(camera, encoded.size(), panorama.size());
  cv::Mat fromLinear, fromEncoded;
  stitcher.stitch(linear, fromLinear);
  stitcher.stitchEncoded(encoded, response, fromEncoded);
  const double linearPsnr = weightedPsnr(fromLinear, panorama, 1.0);
  const double encodedPsnr = weightedPsnr(fromEncoded, panorama, 1.0);
  std::cout << "8-bit sRGB frame: stitch of the linearised frame " << linearPsnr
            << " dB, stitchEncoded " << encodedPsnr << " dB\n";
  EXPECT_GE(linearPsnr, 50.0);
  EXPECT_GE(encodedPsnr, 50.0);
  EXPECT_NEAR(encodedPsnr, linearPsnr, 3.0);
  // A per-channel response works too; bad frames and responses throw.
  cv::Mat perChannel;
  cv::merge(std::vector<cv::Mat>{ response, response, response }, perChannel);
  cv::Mat again;
  stitcher.stitchEncoded(encoded, perChannel, again);
  EXPECT_EQ(cv::norm(again, fromEncoded, cv::NORM_INF), 0.0);
  EXPECT_THROW(stitcher.stitchEncoded(linear, response, again), std::invalid_argument);
  EXPECT_THROW(
    stitcher.stitchEncoded(encoded, cv::Mat(1, 255, CV_32FC1), again), std::invalid_argument);
}

// The back lens records 1.3x brighter and tinted (white balance 1.05, 1, 0.9); the stitcher
// only knows the nominal calibration. Automatic matching finds gains 1.365, 1.3, 1.17 within
// 2 % and the round trip stays as good as without mismatch (front lens's exposure). Without
// matching the back hemisphere is 17-37 % off (PSNR < 30 dB).
TEST(DualFisheyeStitcher, AutomaticGainMatchingUndoesAnExposureMismatch)
{
  const cv::Mat panorama = makePanorama(cv::Size(256, 128), testScene, 4);
  FisheyeCalibration truth = testCamera();
  truth.Back.ExposureGain = 1.3;
  truth.Back.WhiteBalance = { { 1.05, 1.0, 0.9 } };
  const FisheyeCalibration nominal = testCamera();
  const RoundTrip matched = roundTrip(panorama, truth, nominal, cv::Size(1024, 512));
  std::cout << "exposure mismatch, matched: gains " << matched.Gain[0] << ", " << matched.Gain[1]
            << ", " << matched.Gain[2] << "; PSNR away " << matched.AwayFromSeam << " dB, band "
            << matched.InSeamBand << " dB\n";
  const double expected[3] = { 1.3 * 1.05, 1.3, 1.3 * 0.9 };
  for (int c = 0; c < 3; ++c)
  {
    EXPECT_NEAR(matched.Gain[c] / expected[c], 1.0, 0.02) << "channel " << c;
  }
  EXPECT_GE(matched.AwayFromSeam, MinimumPsnrAwayFromSeam);
  EXPECT_GE(matched.InSeamBand, MinimumPsnrInSeamBand);

  FisheyeCalibration unmatched = nominal;
  unmatched.Stitching.AutomaticGainMatching = false;
  const RoundTrip off = roundTrip(panorama, truth, unmatched, cv::Size(1024, 512));
  std::cout << "exposure mismatch, not matched: PSNR away " << off.AwayFromSeam << " dB\n";
  EXPECT_LT(off.AwayFromSeam, 30.0);
  EXPECT_EQ(off.Gain[0], 1.0);
}

// A calibrated exposure/white balance (in the calibration) is divided out exactly, with
// matching off.
TEST(DualFisheyeStitcher, CalibratedGainsAreDividedOut)
{
  const cv::Mat panorama = makePanorama(cv::Size(256, 128), testScene, 4);
  FisheyeCalibration truth = testCamera();
  truth.Front.ExposureGain = 0.8;
  truth.Front.WhiteBalance = { { 0.9, 1.0, 1.2 } };
  truth.Back.ExposureGain = 1.25;
  truth.Back.WhiteBalance = { { 1.1, 1.0, 0.85 } };
  truth.Stitching.AutomaticGainMatching = false;
  const RoundTrip result = roundTrip(panorama, truth, truth, cv::Size(1024, 512));
  std::cout << "calibrated gains: PSNR away " << result.AwayFromSeam << " dB, band "
            << result.InSeamBand << " dB\n";
  EXPECT_GE(result.AwayFromSeam, MinimumPsnrAwayFromSeam);
  EXPECT_GE(result.InSeamBand, MinimumPsnrInSeamBand);
}

// Vignetting rendered into the frame (down to V = 0.55 at the circle edge) is undone when the
// calibration knows it (as good as without vignetting), and visibly not when it does not
// (< 25 dB).
TEST(DualFisheyeStitcher, VignettingIsCorrected)
{
  const cv::Mat panorama = makePanorama(cv::Size(256, 128), testScene, 4);
  FisheyeCalibration vignetted = testCamera();
  vignetted.Front.Vignetting = { { -0.35, -0.05, -0.05 } };
  vignetted.Back.Vignetting = { { -0.25, -0.15, 0.02 } };
  const RoundTrip corrected = roundTrip(panorama, vignetted, vignetted, cv::Size(1024, 512));
  const RoundTrip uncorrected = roundTrip(panorama, vignetted, testCamera(), cv::Size(1024, 512));
  std::cout << "vignetting: corrected PSNR away " << corrected.AwayFromSeam << " dB, band "
            << corrected.InSeamBand << " dB; uncorrected away " << uncorrected.AwayFromSeam
            << " dB\n";
  EXPECT_GE(corrected.AwayFromSeam, MinimumPsnrAwayFromSeam);
  EXPECT_GE(corrected.InSeamBand, MinimumPsnrInSeamBand);
  EXPECT_LT(uncorrected.AwayFromSeam, 25.0);
}

namespace
{
struct LightEstimate
{
  glm::dvec3 Direction;
  double Flux = 0.0;
};

// Solid-angle weighted centroid and flux of (radiance - background) above 10x background.
LightEstimate measureLight(const cv::Mat& panorama, double background)
{
  glm::dvec3 sum(0.0);
  double flux = 0.0;
  const double pixelSolidAngle = (2.0 * PiD / panorama.cols) * (PiD / panorama.rows);
  for (int y = 0; y < panorama.rows; ++y)
  {
    for (int x = 0; x < panorama.cols; ++x)
    {
      const cv::Vec3f& value = panorama.at<cv::Vec3f>(y, x);
      const double excess = (value[0] + value[1] + value[2]) / 3.0 - background;
      if (excess < 10.0 * background)
      {
        continue;
      }
      const glm::dvec3 d = directionOfPixel(x, y, panorama.size());
      const double w = excess * std::sqrt(1.0 - d.y * d.y) * pixelSolidAngle;
      sum += w * d;
      flux += w;
    }
  }
  return { glm::normalize(sum), flux };
}
}

// A 20-degree disk at 1000x the background, inside the front lens and straddling the seam,
// lands at its direction within 1 degree, with its flux within 2 %.
TEST(DualFisheyeStitcher, KnownLightLandsAtItsDirection)
{
  const double background = 0.05;
  const FisheyeCalibration camera = testCamera();
  const glm::dvec3 directions[] = { glm::normalize(glm::dvec3(0.35, 0.5, -0.8)),
    glm::normalize(glm::dvec3(1.0, 0.3, 0.02)), glm::normalize(glm::dvec3(-0.2, -0.3, 1.0)) };
  for (const glm::dvec3& lightDirection : directions)
  {
    const double cosRadius = std::cos(10.0 * PiD / 180.0);
    const cv::Mat panorama = makePanorama(
      cv::Size(512, 256),
      [&](const glm::dvec3& d)
      {
        const double value =
          glm::dot(d, lightDirection) >= cosRadius ? 1000.0 * background : background;
        return cv::Vec3d(value, value, value);
      },
      4);
    const LightEstimate truth = measureLight(panorama, background);
    const cv::Mat frame = renderDualFisheye(panorama, camera, cv::Size(1024, 512));
    DualFisheyeStitcher stitcher;
    stitcher.configure(camera, frame.size(), cv::Size(512, 256));
    cv::Mat stitched;
    stitcher.stitch(frame, stitched);
    const LightEstimate found = measureLight(stitched, background);
    const double errorDegrees =
      std::acos(std::clamp(glm::dot(found.Direction, lightDirection), -1.0, 1.0)) * 180.0 / PiD;
    std::cout << "light at (" << lightDirection.x << ", " << lightDirection.y << ", "
              << lightDirection.z << "): direction error " << errorDegrees << " deg, flux ratio "
              << found.Flux / truth.Flux << "\n";
    EXPECT_LT(errorDegrees, 1.0);
    EXPECT_NEAR(found.Flux / truth.Flux, 1.0, 0.02);
  }
}

// The clipped-pixel mask of the frame comes out where the clipped light is, in both depths.
TEST(DualFisheyeStitcher, SaturationMaskFollowsClippedPixels)
{
  const glm::dvec3 lightDirection = glm::normalize(glm::dvec3(1.0, 0.2, 0.0)); // on the seam
  const cv::Mat panorama = makePanorama(
    cv::Size(256, 128),
    [&](const glm::dvec3& d)
    {
      const double value = glm::dot(d, lightDirection) >= std::cos(0.2) ? 5.0 : 0.2;
      return cv::Vec3d(value, value, value);
    },
    2);
  const FisheyeCalibration camera = testCamera();
  cv::Mat frame = renderDualFisheye(panorama, camera, cv::Size(1024, 512));
  cv::Mat clipped8;
  cv::Mat grey;
  cv::cvtColor(frame, grey, cv::COLOR_RGB2GRAY);
  cv::threshold(grey, grey, 1.0, 1.0, cv::THRESH_BINARY);
  grey.convertTo(clipped8, CV_8U, 255.0);
  frame = cv::min(frame, 1.0); // what the sensor records
  DualFisheyeStitcher stitcher;
  stitcher.configure(camera, frame.size(), panorama.size());
  cv::Mat stitched, mask8, mask32;
  stitcher.stitch(frame, clipped8, stitched, mask8);
  stitcher.stitch(frame, grey, stitched, mask32);
  ASSERT_EQ(mask8.type(), CV_8UC1);
  ASSERT_EQ(mask32.type(), CV_32FC1);
  int inside = 0, insideMasked = 0, outside = 0, outsideMasked = 0;
  for (int y = 0; y < panorama.rows; ++y)
  {
    for (int x = 0; x < panorama.cols; ++x)
    {
      const double angle = std::acos(
        std::clamp(glm::dot(directionOfPixel(x, y, panorama.size()), lightDirection), -1.0, 1.0));
      if (angle < 0.15)
      {
        ++inside;
        insideMasked += mask8.at<std::uint8_t>(y, x) == 255 && mask32.at<float>(y, x) > 0.999f;
      }
      else if (angle > 0.3)
      {
        ++outside;
        outsideMasked += mask8.at<std::uint8_t>(y, x) != 0 || mask32.at<float>(y, x) != 0.0f;
      }
    }
  }
  ASSERT_GT(inside, 20);
  EXPECT_EQ(insideMasked, inside);
  EXPECT_EQ(outsideMasked, 0);
}

// Gain smoothing s = 0.5: after a jump of the true gain from 1.2 to 1.5 the estimate moves
// half-way in log space (sqrt(1.2 * 1.5)), within 2 %.
TEST(DualFisheyeStitcher, GainSmoothingBlendsEstimatesOverTime)
{
  const cv::Mat panorama = makePanorama(cv::Size(256, 128), testScene, 2);
  FisheyeCalibration nominal = testCamera();
  nominal.Stitching.GainSmoothing = 0.5;
  DualFisheyeStitcher stitcher;
  stitcher.configure(nominal, cv::Size(1024, 512), panorama.size());
  cv::Mat stitched;
  FisheyeCalibration truth = testCamera();
  truth.Back.ExposureGain = 1.2;
  stitcher.stitch(renderDualFisheye(panorama, truth, cv::Size(1024, 512), 2), stitched);
  EXPECT_NEAR(stitcher.backToFrontGain()[1], 1.2, 0.024);
  truth.Back.ExposureGain = 1.5;
  stitcher.stitch(renderDualFisheye(panorama, truth, cv::Size(1024, 512), 2), stitched);
  EXPECT_NEAR(stitcher.backToFrontGain()[1] / std::sqrt(1.2 * 1.5), 1.0, 0.02);
  EXPECT_GT(stitcher.gainMatchSampleCount(), 1000);
  stitcher.resetGainMatching();
  EXPECT_EQ(stitcher.backToFrontGain()[1], 1.0);
}

// The blend weights: 1 on the front axis, 0 on the back axis, 0.5 on the seam, and the
// effective band is the requested 8 degrees (the 10-degree overlap leaves room for it).
TEST(DualFisheyeStitcher, BlendWeightsFeatherAcrossTheSeam)
{
  DualFisheyeStitcher stitcher;
  stitcher.configure(testCamera(), cv::Size(1024, 512), cv::Size(512, 256));
  EXPECT_DOUBLE_EQ(stitcher.effectiveBlendBandDegrees(), 8.0);
  const cv::Mat weight = stitcher.frontWeight();
  EXPECT_FLOAT_EQ(weight.at<float>(128, 256), 1.0f); // -Z, front axis
  EXPECT_FLOAT_EQ(weight.at<float>(128, 0), 0.0f);   // +Z, back axis
  // Along the equator the weight falls monotonically from the front axis to the back axis
  // and passes 0.5 at +X (column 384, at 90 degrees from both axes).
  for (int x = 256; x < 511; ++x)
  {
    EXPECT_GE(weight.at<float>(128, x), weight.at<float>(128, x + 1)) << "column " << x;
  }
  EXPECT_NEAR(0.5 * (weight.at<float>(128, 383) + weight.at<float>(128, 384)), 0.5, 1e-3);
  // The transition spans 8 degrees = 11.4 columns of 0.703 degrees.
  int transition = 0;
  for (int x = 256; x < 512; ++x)
  {
    const float w = weight.at<float>(128, x);
    transition += w > 0.0f && w < 1.0f;
  }
  EXPECT_NEAR(transition, 8.0 / (360.0 / 512), 1.0);

  // A band wider than the overlap is clamped to it (less the bilinear margins).
  FisheyeCalibration wide = testCamera();
  wide.Stitching.BlendBandDegrees = 30.0;
  stitcher.configure(wide, cv::Size(1024, 512), cv::Size(512, 256));
  EXPECT_LT(stitcher.effectiveBlendBandDegrees(), 10.0);
  EXPECT_GT(stitcher.effectiveBlendBandDegrees(), 8.0);
}

// Bottom-up frames and panoramas (VTK's row order) give the mirror image of the top-down
// result: stitch(flip(frame)) = flip(stitch(frame)) up to the 1/32-pixel rounding of the
// fixed-point tables (max difference below 1 % of full scale, PSNR above 60 dB).
TEST(DualFisheyeStitcher, BottomUpRowOrderMirrorsTheResult)
{
  const cv::Mat panorama = makePanorama(cv::Size(256, 128), testScene, 2);
  const FisheyeCalibration camera = testCamera();
  const cv::Mat frame = renderDualFisheye(panorama, camera, cv::Size(1024, 512), 2);
  DualFisheyeStitcher topDown, bottomUp;
  topDown.configure(camera, frame.size(), panorama.size());
  hv::lighting::DualFisheyeStitcherOptions options;
  options.FrameBottomUp = true;
  options.PanoramaBottomUp = true;
  bottomUp.configure(camera, frame.size(), panorama.size(), options);
  cv::Mat expected, flippedFrame, mirrored, result;
  topDown.stitch(frame, expected);
  cv::flip(frame, flippedFrame, 0);
  bottomUp.stitch(flippedFrame, mirrored);
  cv::flip(mirrored, result, 0);
  EXPECT_LT(cv::norm(result, expected, cv::NORM_INF), 0.01);
  EXPECT_GT(weightedPsnr(result, expected, 1.0), 60.0);
  EXPECT_EQ(cv::countNonZero(bottomUp.overlapMask() != topDown.overlapMask()), 0);
}

// Lenses narrower than 180 degrees leave a black gap instead of wrapping around.
TEST(DualFisheyeStitcher, UncoveredDirectionsAreBlack)
{
  FisheyeCalibration narrow = testCamera();
  narrow.Front.FieldOfViewDegrees = 170.0;
  narrow.Back.FieldOfViewDegrees = 170.0;
  const cv::Mat panorama = makePanorama(cv::Size(256, 128), testScene, 1);
  DualFisheyeStitcher stitcher;
  stitcher.configure(narrow, cv::Size(1024, 512), panorama.size());
  cv::Mat stitched;
  stitcher.stitch(renderDualFisheye(panorama, narrow, cv::Size(1024, 512), 1), stitched);
  EXPECT_EQ(stitched.at<cv::Vec3f>(64, 192), cv::Vec3f(0, 0, 0)); // +X: 90 degrees from both
  EXPECT_GT(stitched.at<cv::Vec3f>(64, 128)[0], 0.0f);            // -Z: front axis
  EXPECT_EQ(cv::countNonZero(stitcher.overlapMask()), 0);
}

TEST(DualFisheyeStitcher, BadInputThrows)
{
  const FisheyeCalibration camera = testCamera();
  DualFisheyeStitcher stitcher;
  cv::Mat panorama;
  EXPECT_THROW(stitcher.stitch(cv::Mat(512, 1024, CV_32FC3), panorama), std::logic_error);
  // Output not 2:1.
  EXPECT_THROW(
    stitcher.configure(camera, cv::Size(1024, 512), cv::Size(500, 256)), std::invalid_argument);
  // A 16:9 frame for a 2:1 calibration.
  try
  {
    stitcher.configure(camera, cv::Size(1920, 1080));
    ADD_FAILURE() << "a 16:9 frame was accepted";
  }
  catch (const std::invalid_argument& error)
  {
    EXPECT_NE(std::string(error.what()).find("aspect ratio"), std::string::npos) << error.what();
  }
  stitcher.configure(camera, cv::Size(1024, 512));
  // 8-bit, greyscale, or another size than configured.
  EXPECT_THROW(stitcher.stitch(cv::Mat(512, 1024, CV_8UC3, cv::Scalar::all(0)), panorama),
    std::invalid_argument);
  EXPECT_THROW(stitcher.stitch(cv::Mat(512, 1024, CV_32FC1, cv::Scalar::all(0)), panorama),
    std::invalid_argument);
  EXPECT_THROW(stitcher.stitch(cv::Mat(256, 512, CV_32FC3, cv::Scalar::all(0)), panorama),
    std::invalid_argument);
  cv::Mat mask;
  EXPECT_THROW(stitcher.stitch(cv::Mat(512, 1024, CV_32FC3, cv::Scalar::all(0)),
                 cv::Mat(512, 1024, CV_16UC1, cv::Scalar::all(0)), panorama, mask),
    std::invalid_argument);
  // A frame that is black (a covered lens) stitches to black without dividing by zero.
  stitcher.stitch(cv::Mat(512, 1024, CV_32FC3, cv::Scalar::all(0)), panorama);
  EXPECT_EQ(cv::countNonZero(panorama.reshape(1)), 0);
  EXPECT_EQ(stitcher.backToFrontGain()[0], 1.0);
}
