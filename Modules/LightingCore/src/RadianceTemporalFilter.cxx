// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/RadianceTemporalFilter.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace hv
{
namespace lighting
{
RadianceTemporalFilter::RadianceTemporalFilter(const Parameters& parameters)
{
  this->setParameters(parameters);
}

void RadianceTemporalFilter::setParameters(const Parameters& parameters)
{
  if (!(parameters.MinBlend > 0.0f && parameters.MinBlend <= 1.0f))
  {
    throw std::invalid_argument("RadianceTemporalFilter: MinBlend must lie in (0, 1] (1 turns "
                                "the smoothing off; 0.2 averages about five frames).");
  }
  if (!(parameters.LowThreshold >= 0.0f && parameters.LowThreshold < parameters.HighThreshold &&
        parameters.HighThreshold <= 1.0f))
  {
    throw std::invalid_argument("RadianceTemporalFilter: the thresholds on T must satisfy "
                                "0 <= LowThreshold < HighThreshold <= 1.");
  }
  this->Params = parameters;
}

float RadianceTemporalFilter::blendWeight(float t) const
{
  const float low = this->Params.LowThreshold;
  const float high = this->Params.HighThreshold;
  if (t <= low)
  {
    return this->Params.MinBlend;
  }
  if (t >= high)
  {
    return 1.0f;
  }
  const float s = (t - low) / (high - low);
  const float smooth = s * s * (3.0f - 2.0f * s);
  return this->Params.MinBlend + (1.0f - this->Params.MinBlend) * smooth;
}

const cv::Mat& RadianceTemporalFilter::apply(const cv::Mat& radiance, float t)
{
  if (radiance.empty() || radiance.type() != CV_32FC3)
  {
    throw std::invalid_argument("RadianceTemporalFilter::apply: expected a non-empty CV_32FC3 "
                                "radiance map.");
  }
  if (radiance.cols != 2 * radiance.rows)
  {
    throw std::invalid_argument("RadianceTemporalFilter::apply: the radiance map is " +
      std::to_string(radiance.cols) + "x" + std::to_string(radiance.rows) +
      "; an equirectangular panorama is twice as wide as high.");
  }
  if (!(t >= 0.0f && t <= 1.0f))
  {
    throw std::invalid_argument("RadianceTemporalFilter::apply: the illumination difference T "
                                "must lie in [0, 1] (got NaN or a value outside).");
  }
  if (!cv::checkRange(radiance))
  {
    throw std::invalid_argument("RadianceTemporalFilter::apply: the radiance map holds NaN or "
                                "infinite values; fix the radiance estimation upstream.");
  }
  if (this->History.empty() || this->History.size() != radiance.size())
  {
    radiance.copyTo(this->History);
    this->LastBlend = 1.0f;
    return this->History;
  }
  this->LastBlend = this->blendWeight(t);
  if (this->LastBlend >= 1.0f)
  {
    radiance.copyTo(this->History);
  }
  else
  {
    cv::addWeighted(
      radiance, this->LastBlend, this->History, 1.0 - this->LastBlend, 0.0, this->History);
  }
  return this->History;
}

void RadianceTemporalFilter::apply(const cv::Mat& radiance, float t, cv::Mat& filtered)
{
  this->apply(radiance, t).copyTo(filtered);
}

void RadianceTemporalFilter::reset()
{
  this->History.release();
  this->LastBlend = 1.0f;
}
}
}
