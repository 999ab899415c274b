// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_lighting_LensGlare_h
#define hv_lighting_LensGlare_h

#include <opencv2/core.hpp>

namespace hv
{
namespace lighting
{
// The point-spread function of a camera lens as the light-source estimator models it
// (Documentation/HDREstimation.md): a Gaussian core of CoreSigmaDegrees holding 1 - HaloFraction
// of the energy and a wide Gaussian glare halo of HaloSigmaDegrees holding HaloFraction.
struct LensGlare
{
  double CoreSigmaDegrees = 1.0;
  double HaloFraction = 0.02;
  double HaloSigmaDegrees = 5.0;
};

// Films a linear equirectangular panorama (CV_32FC3) through that PSF, for simulations and
// tests: each Gaussian is applied as an angular blur, vertically with sigma and along each row
// with sigma / sin(theta) (wrapping in longitude), which approximates an isotropic blur on the
// sphere away from the poles and keeps every row's energy.
void applyLensGlare(const cv::Mat& linearPanorama, cv::Mat& filmed, const LensGlare& glare);
}
}

#endif
