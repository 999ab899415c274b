// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_ToneMapping_h
#define hv_ToneMapping_h

#include "hv/Platform.h"

#include <cstdint>

namespace hv
{
enum ToneMappingOperator : int
{
  ToneMapClamp = 0,
  ToneMapACES = 1
};

// Narkowicz 2015, "ACES Filmic Tone Mapping Curve": a rational fit of the ACES reference
// rendering transform, applied per channel.
HV_FUNCTION float toneMapACES(float x)
{
  return clampf((x * (2.51f * x + 0.03f)) / (x * (2.43f * x + 0.59f) + 0.14f), 0.0f, 1.0f);
}

// The sRGB transfer function (IEC 61966-2-1).
HV_FUNCTION float encodeSRGB(float linear)
{
  return linear <= 0.0031308f ? 12.92f * linear : 1.055f * glm::pow(linear, 1.0f / 2.4f) - 0.055f;
}

// Display value of one premultiplied linear RGBA pixel: un-premultiply, scale by the exposure
// (a linear factor, 2^stops), tone-map, encode as sRGB and premultiply again, 8 bits each.
HV_FUNCTION void toneMapPixel(
  const float* rgba, float exposureScale, int toneOperator, std::uint8_t* out)
{
  const float alpha = clampf(rgba[3], 0.0f, 1.0f);
  for (int c = 0; c < 3; ++c)
  {
    float value = alpha > 0.0f ? rgba[c] / alpha * exposureScale : 0.0f;
    value = toneOperator == ToneMapACES ? toneMapACES(value) : clampf(value, 0.0f, 1.0f);
    out[c] = static_cast<std::uint8_t>(encodeSRGB(value) * alpha * 255.0f + 0.5f);
  }
  out[3] = static_cast<std::uint8_t>(alpha * 255.0f + 0.5f);
}
}

#endif
