// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Quality figures of denoised frames as the viewer sees them: premultiplied linear RGBA is
// tone-mapped with the mapper's display transform (ACES filmic fit, sRGB encoding,
// premultiplied) to [0, 1], and compared there. Shared by the tests and the evaluation.
#ifndef hv_denoise_ImageQuality_h
#define hv_denoise_ImageQuality_h

#include "hv/ToneMapping.h"

#include <cmath>
#include <cstddef>
#include <vector>

namespace hv
{
namespace denoise
{
// Display RGB in [0, 1], 3 values per pixel, of `pixels` premultiplied linear RGBA pixels.
inline std::vector<float> displayImage(const float* rgba, std::size_t pixels, float exposure = 1.0f)
{
  std::vector<float> display(3 * pixels);
  for (std::size_t i = 0; i < pixels; ++i)
  {
    const float alpha = clampf(rgba[4 * i + 3], 0.0f, 1.0f);
    for (int c = 0; c < 3; ++c)
    {
      const float value = alpha > 0.0f ? rgba[4 * i + c] / alpha * exposure : 0.0f;
      display[3 * i + c] = encodeSRGB(toneMapACES(value)) * alpha;
    }
  }
  return display;
}

inline double meanSquaredError(const std::vector<float>& a, const std::vector<float>& b)
{
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
  {
    const double d = static_cast<double>(a[i]) - static_cast<double>(b[i]);
    sum += d * d;
  }
  return a.empty() ? 0.0 : sum / static_cast<double>(a.size());
}

// PSNR in dB of display images with peak 1; 99 dB when identical.
inline double displayPSNR(const std::vector<float>& image, const std::vector<float>& reference)
{
  const double mse = meanSquaredError(image, reference);
  return mse > 0.0 ? -10.0 * std::log10(mse) : 99.0;
}
}
}

#endif
