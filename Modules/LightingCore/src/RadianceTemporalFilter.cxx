// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/RadianceTemporalFilter.h"

#include "SimdClones.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>

namespace hv
{
namespace lighting
{
namespace
{
// out = a in + (1 - a) history (out = in when history is null); false when `in` holds a NaN or
// an infinity. Float bits with an all-ones exponent are exactly the non-finite values; the test
// is an integer OR, so the loop vectorises.
HV_SIMD_CLONES
bool blendRow(int count, const float* __restrict in, const float* __restrict history, float a,
  float* __restrict out)
{
  std::uint32_t nonFinite = 0;
  if (history)
  {
    const float b = 1.0f - a;
    for (int i = 0; i < count; ++i)
    {
      std::uint32_t bits;
      std::memcpy(&bits, in + i, sizeof(bits));
      nonFinite |= (bits & 0x7f800000u) + 0x00800000u;
      out[i] = in[i] * a + history[i] * b;
    }
  }
  else
  {
    for (int i = 0; i < count; ++i)
    {
      std::uint32_t bits;
      std::memcpy(&bits, in + i, sizeof(bits));
      nonFinite |= (bits & 0x7f800000u) + 0x00800000u;
      out[i] = in[i];
    }
  }
  // (exponent + 1) carries into bit 31 only for an all-ones exponent.
  return (nonFinite & 0x80000000u) == 0;
}
}

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
  const bool restart = this->History.empty() || this->History.size() != radiance.size();
  const float a = restart ? 1.0f : this->blendWeight(t);
  // Q_out = a Q + (1 - a) Q_out(t-1), written to the spare buffer in the same pass that checks Q
  // for NaN and infinities (cv::checkRange and cv::addWeighted took twice as long, and a
  // separate check a pass of its own): on bad input the history is untouched.
  this->Next.create(radiance.size(), CV_32FC3);
  const int count = radiance.cols * 3;
  bool finite = true;
  for (int y = 0; y < radiance.rows; ++y)
  {
    const float* in = radiance.ptr<float>(y);
    float* out = this->Next.ptr<float>(y);
    if (a >= 1.0f)
    {
      finite = blendRow(count, in, nullptr, 1.0f, out) && finite;
    }
    else
    {
      finite = blendRow(count, in, this->History.ptr<float>(y), a, out) && finite;
    }
  }
  if (!finite)
  {
    throw std::invalid_argument("RadianceTemporalFilter::apply: the radiance map holds NaN or "
                                "infinite values; fix the radiance estimation upstream.");
  }
  std::swap(this->History, this->Next);
  this->LastBlend = a;
  return this->History;
}

void RadianceTemporalFilter::apply(const cv::Mat& radiance, float t, cv::Mat& filtered)
{
  this->apply(radiance, t).copyTo(filtered);
}

void RadianceTemporalFilter::reset()
{
  this->History.release();
  this->Next.release();
  this->LastBlend = 1.0f;
}
}
}
