// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_lighting_PanoramaMetrics_h
#define hv_lighting_PanoramaMetrics_h

#include <opencv2/core.hpp>

#include <glm/glm.hpp>

#include <array>

namespace hv
{
namespace lighting
{
// Quality measures for equirectangular panoramas (conventions in Panorama.h). Texels are
// weighted by sin(theta), their share of the sphere, as in the WS-PSNR of Sun et al. 2017
// ("Weighted-to-spherically-uniform quality evaluation for omnidirectional video"), so that
// the stretched polar rows do not dominate.

// Per-texel weight: sin(theta) times the mask (CV_8U, non-zero = counted; empty = all).
cv::Mat sphericalWeights(cv::Size size, const cv::Mat& mask = cv::Mat());

// Weighted PSNR over all channels; peak is the data range (255 for 8-bit images). Returns
// +infinity for identical images.
double weightedPsnr(
  const cv::Mat& image, const cv::Mat& reference, double peak, const cv::Mat& mask = cv::Mat());

// Weighted mean SSIM (Wang et al. 2004: Gaussian window sigma 1.5, K1 = 0.01, K2 = 0.03)
// averaged over the channels.
double weightedSsim(
  const cv::Mat& image, const cv::Mat& reference, double peak, const cv::Mat& mask = cv::Mat());

// Radiance projected on the real spherical harmonics up to order 2 (the basis of
// hv::evaluateSHBasis), integrating over texel solid angles.
std::array<glm::vec3, 9> projectOnSphericalHarmonics(const cv::Mat& linearPanorama);

// Relative RMS error of the diffuse irradiance E(n) (luminance, from the order-2 projection,
// Ramamoorthi & Hanrahan 2001) over `normals` directions spread evenly on the sphere:
//   sqrt( sum_n (E_est(n) - E_ref(n))^2 / sum_n E_ref(n)^2 ).
double irradianceRelativeRmse(
  const cv::Mat& estimate, const cv::Mat& reference, int normals = 2048);

// Weighted RMS of log10 luminance differences, with luminance floored at `floor`.
double logLuminanceRmse(const cv::Mat& estimate, const cv::Mat& reference, double floor = 1e-3);

// The brightest compact light of an HDR panorama: the connected region around the
// luminance maximum above half of it (after a light blur), if it carries at least
// `minimumFluxFraction` of the panorama's total luminous power and is compact (at most
// `maximumSolidAngle` steradians, 1 sr being a cone of 32 degrees half-angle); otherwise Found
// is false ("the panorama has no dominant light").
struct DominantLight
{
  bool Found = false;
  glm::vec3 Direction = glm::vec3(0.0f); // flux-weighted mean direction
  double FluxFraction = 0.0;             // share of the panorama's sin-weighted luminance
  double SolidAngle = 0.0;               // steradians
};
DominantLight findDominantLight(
  const cv::Mat& linearPanorama, double minimumFluxFraction = 0.05, double maximumSolidAngle = 1.0);

// Angle between two directions in degrees.
double angleBetweenDegrees(const glm::vec3& a, const glm::vec3& b);
}
}

#endif
