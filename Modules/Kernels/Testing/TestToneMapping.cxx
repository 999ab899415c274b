// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Display transform of ToneMapping.h: ACES fit, sRGB encoding and 8-bit premultiplied output.
#include "hv/ToneMapping.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

namespace
{
// The IEC 61966-2-1 sRGB encoding in double, as the reference.
double srgb(double x)
{
  return x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055;
}
}

TEST(ToneMapping, SRGBEncoding)
{
  EXPECT_EQ(hv::encodeSRGB(0.0f), 0.0f);
  EXPECT_NEAR(hv::encodeSRGB(1.0f), 1.0f, 1e-6f);
  EXPECT_NEAR(hv::encodeSRGB(0.18f), 0.4613561, 1e-5f); // middle grey
  // Continuous at the linear/power threshold, and monotonic.
  EXPECT_NEAR(hv::encodeSRGB(0.0031308f), hv::encodeSRGB(0.0031309f), 1e-5f);
  float previous = -1.0f;
  for (int i = 0; i <= 1000; ++i)
  {
    const float x = i / 1000.0f;
    const float y = hv::encodeSRGB(x);
    EXPECT_NEAR(y, srgb(x), 2e-6);
    EXPECT_GE(y, previous);
    previous = y;
  }
}

TEST(ToneMapping, ACESCurve)
{
  EXPECT_EQ(hv::toneMapACES(0.0f), 0.0f);
  // Narkowicz's fit: 0.18 maps to ~0.267, and it saturates at 1.
  EXPECT_NEAR(hv::toneMapACES(0.18f),
    0.18 * (2.51 * 0.18 + 0.03) / (0.18 * (2.43 * 0.18 + 0.59) + 0.14), 1e-6);
  EXPECT_EQ(hv::toneMapACES(100.0f), 1.0f);
  float previous = -1.0f;
  for (int i = 0; i <= 2000; ++i)
  {
    const float y = hv::toneMapACES(i / 100.0f);
    EXPECT_GE(y, previous) << "monotonic";
    EXPECT_GE(y, 0.0f);
    EXPECT_LE(y, 1.0f);
    previous = y;
  }
}

TEST(ToneMapping, PremultipliedPixel)
{
  std::uint8_t out[4];
  // Transparent: all zero.
  const float transparent[4] = { 0.3f, 0.2f, 0.1f, 0.0f };
  hv::toneMapPixel(transparent, 1.0f, hv::ToneMapClamp, out);
  EXPECT_EQ(out[0], 0);
  EXPECT_EQ(out[1], 0);
  EXPECT_EQ(out[2], 0);
  EXPECT_EQ(out[3], 0);
  // Opaque white saturates.
  const float white[4] = { 5.0f, 1.0f, 1.0f, 1.0f };
  hv::toneMapPixel(white, 1.0f, hv::ToneMapClamp, out);
  EXPECT_EQ(out[0], 255);
  EXPECT_EQ(out[1], 255);
  EXPECT_EQ(out[3], 255);
  // Half-covered: colour un-premultiplied, scaled by the exposure, encoded, premultiplied again.
  const float half[4] = { 0.25f, 0.125f, 0.0f, 0.5f };
  hv::toneMapPixel(half, 2.0f, hv::ToneMapClamp, out);
  EXPECT_NEAR(out[0], srgb(1.0) * 0.5 * 255.0, 1.0);
  EXPECT_NEAR(out[1], srgb(0.5) * 0.5 * 255.0, 1.0);
  EXPECT_EQ(out[2], 0);
  EXPECT_NEAR(out[3], 128, 1);
  hv::toneMapPixel(half, 2.0f, hv::ToneMapACES, out);
  const double aces = 0.5 * (2.51 * 0.5 + 0.03) / (0.5 * (2.43 * 0.5 + 0.59) + 0.14);
  EXPECT_NEAR(out[1], srgb(aces) * 0.5 * 255.0, 1.0);
}
