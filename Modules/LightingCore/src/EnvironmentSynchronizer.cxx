// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/EnvironmentSynchronizer.h"

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace hv
{
namespace lighting
{
namespace
{
using Clock = std::chrono::steady_clock;

double millisecondsSince(Clock::time_point& start)
{
  const Clock::time_point now = Clock::now();
  const double ms = std::chrono::duration<double, std::milli>(now - start).count();
  start = now;
  return ms;
}
}

void EnvironmentSynchronizer::setOutputHeight(int height)
{
  if (height < 0)
  {
    throw std::invalid_argument(
      "EnvironmentSynchronizer: the output height must be positive, or 0 for the input's");
  }
  this->OutputHeight = height;
}

void EnvironmentSynchronizer::setExposure(float exposure)
{
  if (!(exposure > 0.0f) || !std::isfinite(exposure))
  {
    throw std::invalid_argument(
      "EnvironmentSynchronizer: the exposure must be a positive number (1 = the reference "
      "exposure)");
  }
  this->Exposure = exposure;
}

void EnvironmentSynchronizer::reset()
{
  this->Difference.reset();
  this->Filter.reset();
  this->PreviousSmoothed.release();
  this->HasFrame = false;
}

const EnvironmentSynchronizer::Result& EnvironmentSynchronizer::process(
  const cv::Mat& cameraPanorama, PanoramaDynamicRange range, bool newFrame)
{
  if (cameraPanorama.empty() || cameraPanorama.cols != 2 * cameraPanorama.rows)
  {
    throw std::invalid_argument("EnvironmentSynchronizer: the camera panorama must be "
                                "equirectangular, width = 2 x height (got " +
      std::to_string(cameraPanorama.cols) + " x " + std::to_string(cameraPanorama.rows) +
      "); stitch dual-fisheye frames first");
  }
  const int type = cameraPanorama.type();
  if (type != CV_8UC3 && type != CV_16UC3 && type != CV_32FC3)
  {
    throw std::invalid_argument("EnvironmentSynchronizer: the camera panorama must be RGB with "
                                "8-bit, 16-bit or float channels");
  }
  if (type != CV_32FC3 && range == PanoramaDynamicRange::High)
  {
    throw std::invalid_argument("EnvironmentSynchronizer: an 8/16-bit panorama cannot be high "
                                "dynamic range; pass a float (EXR/HDR) panorama or say Low");
  }
  newFrame = newFrame || !this->HasFrame;
  Result& result = this->Last;
  Clock::time_point start = Clock::now();

  const cv::Mat* linear = &cameraPanorama;
  if (type != CV_32FC3)
  {
    this->Response.linearize(cameraPanorama, this->Linear);
    linear = &this->Linear;
  }
  result.LinearizeMilliseconds = millisecondsSince(start);

  // Q in the camera's frame. The light sources are estimated before the volume-centred warp:
  // the estimator models the lens's point-spread function as isotropic around each light,
  // which holds in the camera's panorama but not after the warp stretches it.
  const cv::Mat* cameraRadiance = linear;
  if (range == PanoramaDynamicRange::Low)
  {
    // No copy of the map: Q is composed in place in the linearised frame when that is ours
    // (8/16-bit input); for the caller's float panorama, it is copied only when a light's
    // radiance is restored (otherwise Q is the panorama itself).
    if (linear == &this->Linear)
    {
      this->Estimator.estimate(this->Linear, cv::Mat(), this->Linear, result.Lights);
    }
    else
    {
      bool unchanged = false;
      this->Estimator.estimate(*linear, cv::Mat(), this->Recovered, result.Lights, &unchanged);
      cameraRadiance = unchanged ? linear : &this->Recovered;
    }
  }
  else
  {
    this->Estimator.detect(*linear, result.Lights);
  }
  result.RecoverMilliseconds = millisecondsSince(start);

  // Rotate into the world and re-centre on the volume; the lights follow (their solid angles
  // and radiances stay those seen from the camera).
  const int height = this->OutputHeight > 0 ? this->OutputHeight : cameraPanorama.rows;
  this->Alignment.setOutputSize(2 * height, height);
  this->Alignment.apply(*cameraRadiance, this->Aligned);
  for (DetectedLight& light : result.Lights)
  {
    light.Direction = this->Alignment.volumeDirectionFromCameraDirection(light.Direction);
  }
  // Q in units of the reference exposure.
  if (this->Exposure != 1.0f)
  {
    this->Aligned *= 1.0 / this->Exposure;
    for (DetectedLight& light : result.Lights)
    {
      light.Intensity /= this->Exposure;
      light.Radiance /= this->Exposure;
      light.Peak /= this->Exposure;
      light.Power /= this->Exposure;
      light.SourceRadiance /= this->Exposure;
    }
  }
  result.AlignMilliseconds = millisecondsSince(start);

  if (newFrame)
  {
    result.IlluminationDifference = this->Difference.update(this->Aligned);
    result.PatchSimilarity = this->Difference.patchSimilarity().clone();
  }
  result.DifferenceMilliseconds = millisecondsSince(start);

  if (this->TemporalSmoothing)
  {
    if (newFrame)
    {
      // The smoothed Q of the previous frame is the history this frame starts from; keep it
      // for re-processing this frame (buffers are swapped, not copied).
      if (this->HasFrame)
      {
        std::swap(this->PreviousSmoothed, result.Radiance);
      }
    }
    else
    {
      // Restart from the same history as when the frame first came.
      this->Filter.reset();
      if (!this->PreviousSmoothed.empty())
      {
        this->Filter.apply(this->PreviousSmoothed, 0.0f);
      }
    }
    // Q is the filter's own buffer (a shallow copy): the filter does not write it during its
    // next call, when it becomes PreviousSmoothed, but only in the call after.
    result.Radiance = this->Filter.apply(this->Aligned, result.IlluminationDifference);
    result.TemporalBlendWeight = this->Filter.lastBlendWeight();
  }
  else
  {
    this->Filter.reset();
    this->PreviousSmoothed.release();
    // Q itself is the result (a shallow copy); the next frame is aligned into the other buffer.
    result.Radiance = this->Aligned;
    std::swap(this->Aligned, this->Spare);
    result.TemporalBlendWeight = 1.0f;
  }
  result.SmoothMilliseconds = millisecondsSince(start);
  this->HasFrame = true;
  return result;
}
}
}
