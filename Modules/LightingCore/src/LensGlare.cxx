// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/LensGlare.h"

#include "hv/Platform.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace hv
{
namespace lighting
{
namespace
{
// One angular Gaussian of sigma degrees on an equirectangular panorama.
cv::Mat sphericalGaussian(const cv::Mat& panorama, double sigmaDegrees)
{
  const int width = panorama.cols, height = panorama.rows;
  const double pixelsPerDegree = height / 180.0;
  const double sigmaRows = sigmaDegrees * pixelsPerDegree;
  cv::Mat vertical;
  // Across the poles the reflection stands in for the continuation over the other side.
  cv::GaussianBlur(panorama, vertical,
    cv::Size(1, 2 * static_cast<int>(std::ceil(3.0 * sigmaRows)) + 1), 0.0, sigmaRows,
    cv::BORDER_REFLECT);
  cv::Mat blurred(panorama.size(), CV_32FC3);
  for (int j = 0; j < height; ++j)
  {
    const double sinTheta = std::sin(Pi * (j + 0.5) / height);
    const double sigmaColumns = sigmaRows / std::max(sinTheta, 1e-3);
    const int radius = std::min(static_cast<int>(std::ceil(3.0 * sigmaColumns)), width / 2);
    cv::Mat row;
    cv::copyMakeBorder(vertical.row(j), row, 0, 0, radius, radius, cv::BORDER_WRAP);
    cv::Mat kernel = cv::getGaussianKernel(2 * radius + 1, sigmaColumns, CV_32F);
    // A kernel truncated at half the circumference is renormalised so the row keeps its energy.
    kernel /= cv::sum(kernel)[0];
    cv::Mat filtered;
    cv::filter2D(row, filtered, CV_32F, kernel.t(), cv::Point(-1, -1), 0.0, cv::BORDER_CONSTANT);
    filtered.colRange(radius, radius + width).copyTo(blurred.row(j));
  }
  return blurred;
}
}

void applyLensGlare(const cv::Mat& linearPanorama, cv::Mat& filmed, const LensGlare& glare)
{
  if (linearPanorama.empty() || linearPanorama.type() != CV_32FC3 ||
    linearPanorama.cols != 2 * linearPanorama.rows)
  {
    throw std::invalid_argument(
      "applyLensGlare: expected a linear CV_32FC3 equirectangular panorama (width = 2 x height)");
  }
  if (!(glare.CoreSigmaDegrees > 0.0) || !(glare.HaloSigmaDegrees > 0.0) ||
    !(glare.HaloFraction >= 0.0 && glare.HaloFraction < 1.0))
  {
    throw std::invalid_argument("applyLensGlare: the PSF needs positive widths and a halo "
                                "fraction in [0, 1)");
  }
  const cv::Mat core = sphericalGaussian(linearPanorama, glare.CoreSigmaDegrees);
  if (glare.HaloFraction == 0.0)
  {
    filmed = core;
    return;
  }
  const cv::Mat halo = sphericalGaussian(linearPanorama, glare.HaloSigmaDegrees);
  cv::addWeighted(core, 1.0 - glare.HaloFraction, halo, glare.HaloFraction, 0.0, filmed);
}
}
}
