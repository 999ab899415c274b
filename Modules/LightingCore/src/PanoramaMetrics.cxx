// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/PanoramaMetrics.h"

#include "hv/EnvironmentMap.h"
#include "hv/Equirectangular.h"
#include "hv/Render.h"

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace hv
{
namespace lighting
{
namespace
{
void requirePanorama(const cv::Mat& image, const char* what)
{
  if (image.empty() || image.cols != 2 * image.rows || image.channels() != 3)
  {
    throw std::invalid_argument(std::string("panorama metrics: the ") + what +
      " must be a 3-channel equirectangular panorama (width = 2 x height)");
  }
}

void requireSameShape(const cv::Mat& a, const cv::Mat& b)
{
  requirePanorama(a, "image");
  requirePanorama(b, "reference");
  if (a.size() != b.size() || a.type() != b.type())
  {
    throw std::invalid_argument(
      "panorama metrics: image and reference must have the same size and type");
  }
}

cv::Mat luminanceOf(const cv::Mat& linear)
{
  cv::Mat rgb;
  linear.convertTo(rgb, CV_32F);
  cv::Mat y;
  // Rec. 709 weights in R, G, B order (hv::luminance).
  cv::transform(rgb, y, cv::Matx13f(0.2126f, 0.7152f, 0.0722f));
  return y;
}

double weightedMean(const cv::Mat& values, const cv::Mat& weights)
{
  return values.dot(weights) / std::max(cv::sum(weights)[0], 1e-300);
}
}

cv::Mat sphericalWeights(cv::Size size, const cv::Mat& mask)
{
  cv::Mat weights(size, CV_32F);
  for (int j = 0; j < size.height; ++j)
  {
    weights.row(j).setTo(std::sin(Pi * (j + 0.5f) / size.height));
  }
  if (!mask.empty())
  {
    if (mask.size() != size || mask.type() != CV_8U)
    {
      throw std::invalid_argument("panorama metrics: the mask must be CV_8U of the image's size");
    }
    weights.setTo(0.0f, mask == 0);
  }
  return weights;
}

double weightedPsnr(
  const cv::Mat& image, const cv::Mat& reference, double peak, const cv::Mat& mask)
{
  requireSameShape(image, reference);
  cv::Mat a, b;
  image.convertTo(a, CV_32F);
  reference.convertTo(b, CV_32F);
  cv::Mat difference = a - b;
  cv::Mat squared = difference.mul(difference);
  cv::Mat perTexel;
  cv::transform(squared, perTexel, cv::Matx13f(1.0f / 3.0f, 1.0f / 3.0f, 1.0f / 3.0f));
  const double mse = weightedMean(perTexel, sphericalWeights(image.size(), mask));
  return mse <= 0.0 ? std::numeric_limits<double>::infinity()
                    : 10.0 * std::log10(peak * peak / mse);
}

double weightedSsim(
  const cv::Mat& image, const cv::Mat& reference, double peak, const cv::Mat& mask)
{
  requireSameShape(image, reference);
  const double c1 = (0.01 * peak) * (0.01 * peak);
  const double c2 = (0.03 * peak) * (0.03 * peak);
  cv::Mat a, b;
  image.convertTo(a, CV_32F);
  reference.convertTo(b, CV_32F);
  const cv::Size window(11, 11);
  const double sigma = 1.5;
  cv::Mat muA, muB, aa, bb, ab;
  cv::GaussianBlur(a, muA, window, sigma);
  cv::GaussianBlur(b, muB, window, sigma);
  cv::GaussianBlur(a.mul(a), aa, window, sigma);
  cv::GaussianBlur(b.mul(b), bb, window, sigma);
  cv::GaussianBlur(a.mul(b), ab, window, sigma);
  const cv::Mat muAB = muA.mul(muB);
  const cv::Mat muAA = muA.mul(muA);
  const cv::Mat muBB = muB.mul(muB);
  cv::Mat numerator = (2.0 * muAB + c1).mul(2.0 * (ab - muAB) + c2);
  cv::Mat denominator = (muAA + muBB + c1).mul((aa - muAA) + (bb - muBB) + c2);
  cv::Mat ssim;
  cv::divide(numerator, denominator, ssim);
  cv::Mat perTexel;
  cv::transform(ssim, perTexel, cv::Matx13f(1.0f / 3.0f, 1.0f / 3.0f, 1.0f / 3.0f));
  return weightedMean(perTexel, sphericalWeights(image.size(), mask));
}

std::array<glm::vec3, 9> projectOnSphericalHarmonics(const cv::Mat& linearPanorama)
{
  requirePanorama(linearPanorama, "panorama");
  cv::Mat rgb;
  linearPanorama.convertTo(rgb, CV_32FC3);
  std::array<glm::dvec3, 9> sum{};
  const int width = rgb.cols, height = rgb.rows;
  const double texelSolidAngleScale = (2.0 * Pi / width) * (Pi / height);
  for (int j = 0; j < height; ++j)
  {
    const double solidAngle = texelSolidAngleScale * std::sin(Pi * (j + 0.5) / height);
    const cv::Vec3f* row = rgb.ptr<cv::Vec3f>(j);
    for (int i = 0; i < width; ++i)
    {
      const glm::vec3 d =
        equirectangularToDirection(glm::vec2((i + 0.5f) / width, (j + 0.5f) / height));
      float basis[9];
      evaluateSHBasis(d, basis);
      const glm::dvec3 radiance(row[i][0], row[i][1], row[i][2]);
      for (int k = 0; k < 9; ++k)
      {
        sum[k] += radiance * (basis[k] * solidAngle);
      }
    }
  }
  std::array<glm::vec3, 9> coefficients;
  for (int k = 0; k < 9; ++k)
  {
    coefficients[k] = glm::vec3(sum[k]);
  }
  return coefficients;
}

double irradianceRelativeRmse(const cv::Mat& estimate, const cv::Mat& reference, int normals)
{
  requireSameShape(estimate, reference);
  const std::array<glm::vec3, 9> shEstimate = projectOnSphericalHarmonics(estimate);
  const std::array<glm::vec3, 9> shReference = projectOnSphericalHarmonics(reference);
  double squaredError = 0.0, squaredReference = 0.0;
  // A Fibonacci lattice spreads the normals evenly over the sphere.
  const double goldenAngle = Pi * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < normals; ++k)
  {
    const double y = 1.0 - 2.0 * (k + 0.5) / normals;
    const double r = std::sqrt(std::max(0.0, 1.0 - y * y));
    const glm::vec3 n(static_cast<float>(r * std::cos(goldenAngle * k)), static_cast<float>(y),
      static_cast<float>(r * std::sin(goldenAngle * k)));
    const double eEstimate =
      luminance(glm::max(irradianceFromSH(shEstimate.data(), n), glm::vec3(0.0f)));
    const double eReference =
      luminance(glm::max(irradianceFromSH(shReference.data(), n), glm::vec3(0.0f)));
    squaredError += (eEstimate - eReference) * (eEstimate - eReference);
    squaredReference += eReference * eReference;
  }
  return std::sqrt(squaredError / std::max(squaredReference, 1e-300));
}

double logLuminanceRmse(const cv::Mat& estimate, const cv::Mat& reference, double floor)
{
  requireSameShape(estimate, reference);
  cv::Mat a = cv::max(luminanceOf(estimate), floor);
  cv::Mat b = cv::max(luminanceOf(reference), floor);
  cv::log(a, a);
  cv::log(b, b);
  cv::Mat difference = (a - b) * (1.0 / std::log(10.0));
  const cv::Mat squared = difference.mul(difference);
  return std::sqrt(weightedMean(squared, sphericalWeights(estimate.size())));
}

DominantLight findDominantLight(
  const cv::Mat& linearPanorama, double minimumFluxFraction, double maximumSolidAngle)
{
  requirePanorama(linearPanorama, "panorama");
  // A light blur (about 1 degree) keeps a textured lamp in one piece.
  cv::Mat y = luminanceOf(linearPanorama);
  const int kernel = std::max(3, (linearPanorama.cols / 360) | 1);
  cv::Mat smooth;
  cv::GaussianBlur(y, smooth, cv::Size(kernel, kernel), 0.0, 0.0, cv::BORDER_REFLECT);
  double maximum = 0.0;
  cv::Point peak;
  cv::minMaxLoc(smooth, nullptr, &maximum, nullptr, &peak);
  DominantLight light;
  if (!(maximum > 0.0))
  {
    return light;
  }
  cv::Mat bright = smooth >= 0.5 * maximum;
  // The region may cross the longitude seam: label a copy extended by a wrapped border.
  cv::Mat labels;
  cv::Mat extended;
  const int pad = linearPanorama.cols / 4;
  cv::copyMakeBorder(bright, extended, 0, 0, pad, pad, cv::BORDER_WRAP);
  cv::connectedComponents(extended, labels, 8, CV_32S);
  const int peakLabel = labels.at<int>(peak.y, peak.x + pad);
  const cv::Mat weights = sphericalWeights(y.size());
  const double total = y.dot(weights);
  glm::dvec3 direction(0.0);
  double flux = 0.0, solidAngle = 0.0;
  const double texel = (2.0 * Pi / y.cols) * (Pi / y.rows);
  for (int j = 0; j < y.rows; ++j)
  {
    for (int i = 0; i < y.cols; ++i)
    {
      // Count each texel once: from its own column or one of its wrapped copies.
      const bool inside = labels.at<int>(j, i + pad) == peakLabel ||
        (i < pad && labels.at<int>(j, i + pad + y.cols) == peakLabel) ||
        (i >= y.cols - pad && labels.at<int>(j, i + pad - y.cols) == peakLabel);
      if (!inside)
      {
        continue;
      }
      const double w = weights.at<float>(j, i);
      const double power = y.at<float>(j, i) * w;
      const glm::vec3 d =
        equirectangularToDirection(glm::vec2((i + 0.5f) / y.cols, (j + 0.5f) / y.rows));
      direction += glm::dvec3(d) * power;
      flux += power;
      solidAngle += w * texel;
    }
  }
  light.FluxFraction = flux / std::max(total, 1e-300);
  light.SolidAngle = solidAngle;
  light.Direction =
    glm::length(direction) > 0.0 ? glm::vec3(glm::normalize(direction)) : glm::vec3(0.0f);
  light.Found = light.FluxFraction >= minimumFluxFraction && solidAngle <= maximumSolidAngle &&
    glm::length(direction) > 0.0;
  return light;
}

double angleBetweenDegrees(const glm::vec3& a, const glm::vec3& b)
{
  const double c = glm::dot(glm::normalize(glm::dvec3(a)), glm::normalize(glm::dvec3(b)));
  return std::acos(std::max(-1.0, std::min(1.0, c))) * 180.0 / Pi;
}
}
}
