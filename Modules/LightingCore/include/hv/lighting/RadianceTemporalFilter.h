// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_lighting_RadianceTemporalFilter_h
#define hv_lighting_RadianceTemporalFilter_h

#include <opencv2/core.hpp>

namespace hv
{
namespace lighting
{
// Temporal smoothing of the radiance map Q while the lighting is steady, so that sensor noise
// does not make the rendered lighting flicker; a real change passes through at once.
//   Q_out(t) = Q_out(t-1) + a(T) (Q(t) - Q_out(t-1))      (an exponential moving average)
// with the blend weight a(T) = MinBlend for T <= LowThreshold, 1 (no history) for
// T >= HighThreshold, and a smoothstep between them; T is the illumination difference of
// IlluminationDifference. Under white noise of variance s^2 the steady-state output varies frame
// to frame with a standard deviation a / sqrt(2 - a) times that of the input (MinBlend = 0.2:
// 6.7x less), with a time constant of about 1 / MinBlend frames.
class RadianceTemporalFilter
{
public:
  struct Parameters
  {
    float MinBlend = 0.2f;       // a while the lighting is steady, in (0, 1]
    float LowThreshold = 0.05f;  // T up to which a = MinBlend (sensor noise: T < 0.05)
    float HighThreshold = 0.25f; // T from which a = 1 (one lamp switching: T ~ 0.35-0.65)
  };

  RadianceTemporalFilter() = default;
  explicit RadianceTemporalFilter(const Parameters& parameters);

  // Throws std::invalid_argument unless 0 < MinBlend <= 1 and 0 <= Low < High <= 1.
  void setParameters(const Parameters& parameters);
  const Parameters& parameters() const { return this->Params; }

  // Blends `radiance` (CV_32FC3, 2:1, finite) into the history and returns the filtered map
  // (owned by the filter). The first frame, and a frame whose size differs from the history,
  // is passed through. Throws std::invalid_argument for bad input or T outside [0, 1] / NaN;
  // the history is then left as it was. The filter alternates between two buffers: the map
  // returned by one call is not written by the next call (a caller may keep a shallow copy of
  // it as the previous frame's output for that long), but by the call after.
  const cv::Mat& apply(const cv::Mat& radiance, float illuminationDifference);
  // The same, with a deep copy of the result in `filtered`.
  void apply(const cv::Mat& radiance, float illuminationDifference, cv::Mat& filtered);

  // a(T) as used by apply().
  float blendWeight(float illuminationDifference) const;
  float lastBlendWeight() const { return this->LastBlend; }

  void reset();
  bool hasHistory() const { return !this->History.empty(); }

private:
  Parameters Params;
  cv::Mat History;
  cv::Mat Next; // the buffer the next result is written to, then swapped with History
  float LastBlend = 1.0f;
};
}
}

#endif
