// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_lighting_EnvironmentSynchronizer_h
#define hv_lighting_EnvironmentSynchronizer_h

#include "hv/lighting/CameraResponse.h"
#include "hv/lighting/IlluminationDifference.h"
#include "hv/lighting/LightSourceEstimator.h"
#include "hv/lighting/PanoramaAlignment.h"
#include "hv/lighting/RadianceTemporalFilter.h"

#include <opencv2/core.hpp>

#include <vector>

namespace hv
{
namespace lighting
{
// How the pixel values of a camera-frame panorama relate to radiance.
enum class PanoramaDynamicRange
{
  // Clipped at the sensor's white: 8/16-bit display-referred values, or such values already
  // linearised (the stitcher's output). Light sources are estimated.
  Low,
  // Scene-linear HDR (EXR/HDR input): used as it is.
  High
};

// The per-frame chain of Section 3.1 after stitching, for one camera-frame panorama:
//   linearise (display-referred input) -> recover Q (LDR input) -> rotate into the world and
//   re-centre on the volume -> illumination difference T -> temporal smoothing of Q.
// The radiance is recovered in the camera's panorama, where a light's glare is isotropic as
// the estimator assumes; Q and the detected lights then move to world directions seen from
// the volume, the frame the renderer and T need.
class EnvironmentSynchronizer
{
public:
  struct Result
  {
    cv::Mat Radiance;                    // Q, CV_32FC3 world frame, divided by the exposure
    std::vector<DetectedLight> Lights;   // world directions from the volume centre
    float IlluminationDifference = 0.0f; // T in [0, 1)
    cv::Mat PatchSimilarity;             // N x N CV_32F, empty on the first frame
    float TemporalBlendWeight = 1.0f;    // weight of this frame in the smoothed Q
    // Milliseconds per stage.
    double LinearizeMilliseconds = 0.0;
    double AlignMilliseconds = 0.0;
    double RecoverMilliseconds = 0.0;
    double DifferenceMilliseconds = 0.0;
    double SmoothMilliseconds = 0.0;
    double totalMilliseconds() const
    {
      return LinearizeMilliseconds + AlignMilliseconds + RecoverMilliseconds +
        DifferenceMilliseconds + SmoothMilliseconds;
    }
  };

  CameraResponse& cameraResponse() { return this->Response; }
  PanoramaAlignment& alignment() { return this->Alignment; }
  LightSourceEstimator& estimator() { return this->Estimator; }
  IlluminationDifference& illuminationDifference() { return this->Difference; }
  RadianceTemporalFilter& temporalFilter() { return this->Filter; }

  // Height of Q (width 2 x height); 0 keeps the input's size.
  void setOutputHeight(int height);
  // Exposure of the camera relative to the reference: Q = linear / exposure.
  void setExposure(float exposure);
  void setTemporalSmoothing(bool enabled) { this->TemporalSmoothing = enabled; }

  // Processes a camera-frame equirectangular panorama: CV_8UC3 or CV_16UC3 (display-referred,
  // always low dynamic range) or CV_32FC3 (linear). The pose and volume centre are those set
  // on alignment(). newFrame = false re-processes the frame of the previous call (a new
  // pose, a changed setting): T is kept, and smoothing starts from the same history as then.
  // Throws std::invalid_argument with what to change on bad input.
  const Result& process(const cv::Mat& cameraPanorama, PanoramaDynamicRange range, bool newFrame);

  const Result& result() const { return this->Last; }

  // Forgets the previous frames: the next frame has T close to 1 and no smoothing.
  void reset();

private:
  CameraResponse Response;
  PanoramaAlignment Alignment;
  LightSourceEstimator Estimator;
  IlluminationDifference Difference;
  RadianceTemporalFilter Filter;
  int OutputHeight = 256;
  float Exposure = 1.0f;
  bool TemporalSmoothing = true;
  bool HasFrame = false;

  cv::Mat Linear;    // the linearised frame (8/16-bit input), then Q in the camera's frame
  cv::Mat Recovered; // Q in the camera's frame for float input
  cv::Mat Aligned;   // Q in the world, centred on the volume
  cv::Mat Spare;     // without smoothing, Aligned alternates with it (the result keeps one)
  // The smoothed Q of the previous distinct frame, the history a re-processed frame restarts
  // from.
  cv::Mat PreviousSmoothed;
  Result Last;
};
}
}

#endif
