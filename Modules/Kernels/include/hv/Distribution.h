// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_Distribution_h
#define hv_Distribution_h

#include "hv/Platform.h"

namespace hv
{
// Index of the CDF segment containing u: the largest i in [0, count) with cdf[i] <= u.
// cdf has count + 1 entries, cdf[0] = 0 and cdf[count] = 1.
HV_FUNCTION int findCdfSegment(const float* cdf, int count, float u)
{
  int lo = 0;
  int hi = count; // invariant: cdf[lo] <= u < cdf[hi] (for u < 1)
  while (hi - lo > 1)
  {
    const int mid = (lo + hi) / 2;
    if (cdf[mid] <= u)
    {
      lo = mid;
    }
    else
    {
      hi = mid;
    }
  }
  return lo;
}

// Device-side view of a piecewise-constant 2D distribution on [0,1]^2 (Pharr et al.,
// "Physically Based Rendering", 3rd ed., Sec. 13.6.7): a marginal density over rows and one
// conditional density per row. Built on the host by hv::Distribution2D.
struct Distribution2DView
{
  int width = 0;
  int height = 0;
  const float* function = nullptr;       // width * height, row-major, the unnormalised f
  const float* conditionalCdf = nullptr; // height * (width + 1)
  const float* rowIntegral = nullptr;    // height: integral of f over u for each row
  const float* marginalCdf = nullptr;    // height + 1
  float integral = 0.0f;                 // integral of f over [0,1]^2

  HV_FUNCTION bool valid() const { return this->function != nullptr && this->integral > 0.0f; }

  // Continuous sample in [0,1)^2 with density pdf(u,v) = f(u,v) / integral.
  HV_FUNCTION glm::vec2 sample(float u1, float u2, float& pdf) const
  {
    const int row = findCdfSegment(this->marginalCdf, this->height, u1);
    const float rowLow = this->marginalCdf[row];
    const float rowHigh = this->marginalCdf[row + 1];
    const float dv = rowHigh > rowLow ? (u1 - rowLow) / (rowHigh - rowLow) : 0.5f;
    const float* cdf = this->conditionalCdf + static_cast<long>(row) * (this->width + 1);
    const int column = findCdfSegment(cdf, this->width, u2);
    const float du =
      cdf[column + 1] > cdf[column] ? (u2 - cdf[column]) / (cdf[column + 1] - cdf[column]) : 0.5f;
    pdf = this->function[static_cast<long>(row) * this->width + column] / this->integral;
    return glm::vec2(glm::min((column + du) / this->width, 0.99999994f),
      glm::min((row + dv) / this->height, 0.99999994f));
  }

  HV_FUNCTION float pdf(const glm::vec2& uv) const
  {
    const int column = glm::clamp(static_cast<int>(uv.x * this->width), 0, this->width - 1);
    const int row = glm::clamp(static_cast<int>(uv.y * this->height), 0, this->height - 1);
    return this->function[static_cast<long>(row) * this->width + column] / this->integral;
  }
};
}

#endif
