// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// The small helpers of Platform.h that the kernels share.
#include "hv/Platform.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

namespace
{
// clampf as it was written before it became glm::clamp (so that GCC vectorises the loops that
// call it): the denoiser's evaluation tables stayed bit-identical only if every input gives the
// same bits.
float nestedChoice(float x, float lo, float hi)
{
  return x < lo ? lo : (x > hi ? hi : x);
}

bool sameBits(float a, float b)
{
  return std::memcmp(&a, &b, sizeof(float)) == 0;
}
}

TEST(Platform, ClampfGivesTheNestedChoicesBitsForEveryInput)
{
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float infinity = std::numeric_limits<float>::infinity();
  const float inputs[] = { -infinity, -2.0f, -1.0f, -0.0f, 0.0f, 1e-40f, 0.25f, 1.0f,
    std::nextafter(1.0f, 2.0f), 64.0f, infinity };
  const float bounds[][2] = { { 0.0f, 1.0f }, { -1.0f, 1.0f }, { -80.0f, 80.0f },
    { 1.0f / 64.0f, 64.0f } };
  for (const auto& bound : bounds)
  {
    for (float x : inputs)
    {
      EXPECT_TRUE(sameBits(hv::clampf(x, bound[0], bound[1]), nestedChoice(x, bound[0], bound[1])))
        << "x = " << x << " in [" << bound[0] << ", " << bound[1] << "]";
    }
    EXPECT_TRUE(std::isnan(hv::clampf(nan, bound[0], bound[1]))); // passes through, as before
  }
  // The sign of a zero at the bound is kept.
  EXPECT_TRUE(std::signbit(hv::clampf(-0.0f, 0.0f, 1.0f)));
  EXPECT_FALSE(std::signbit(hv::clampf(0.0f, -0.0f, 1.0f)));
}
