// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/IlluminationDifference.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace hv
{
namespace lighting
{
namespace
{
// Wang et al. (2004): 11 x 11 circular-symmetric Gaussian window, sigma = 1.5 samples.
const cv::Size SsimWindow(11, 11);
constexpr double SsimSigma = 1.5;

void gaussianWindow(const cv::Mat& src, cv::Mat& dst)
{
  cv::GaussianBlur(src, dst, SsimWindow, SsimSigma, SsimSigma, cv::BORDER_REFLECT);
}
}

IlluminationDifference::IlluminationDifference(const Parameters& parameters)
{
  this->setParameters(parameters);
}

void IlluminationDifference::setParameters(const Parameters& parameters)
{
  if (parameters.PatchGrid < 1)
  {
    throw std::invalid_argument(
      "IlluminationDifference: PatchGrid (patches per row and column) must be at least 1.");
  }
  if (!(parameters.LuminanceFloor > 0.0f) || !std::isfinite(parameters.LuminanceFloor))
  {
    throw std::invalid_argument("IlluminationDifference: LuminanceFloor must be a positive "
                                "relative radiance (e.g. 0.01, 1 % of the clip level).");
  }
  if (!(parameters.MaxLuminance > parameters.LuminanceFloor) ||
    !std::isfinite(parameters.MaxLuminance))
  {
    throw std::invalid_argument("IlluminationDifference: MaxLuminance (top of the fixed data "
                                "range) must be finite and above LuminanceFloor.");
  }
  const bool logChanged = parameters.LuminanceFloor != this->Params.LuminanceFloor;
  this->Params = parameters;
  if (logChanged)
  {
    this->reset(); // the cached log-luminance of the previous frame used the old floor
  }
}

void IlluminationDifference::validate(const cv::Mat& radiance, const char* what) const
{
  if (radiance.empty())
  {
    throw std::invalid_argument(
      std::string("IlluminationDifference: the ") + what + " radiance map is empty.");
  }
  if (radiance.type() != CV_32FC3)
  {
    throw std::invalid_argument(std::string("IlluminationDifference: the ") + what +
      " radiance map must be CV_32FC3 linear RGB, got " + cv::typeToString(radiance.type()) + ".");
  }
  if (radiance.cols != 2 * radiance.rows)
  {
    throw std::invalid_argument(std::string("IlluminationDifference: the ") + what +
      " radiance map is " + std::to_string(radiance.cols) + "x" + std::to_string(radiance.rows) +
      "; an equirectangular panorama is twice as wide as high.");
  }
  if (radiance.rows < this->Params.PatchGrid)
  {
    throw std::invalid_argument("IlluminationDifference: the panorama has fewer rows than the "
                                "patch grid; lower PatchGrid or use a larger panorama.");
  }
  if (!cv::checkRange(radiance))
  {
    throw std::invalid_argument(std::string("IlluminationDifference: the ") + what +
      " radiance map holds NaN or infinite values; fix the radiance estimation upstream.");
  }
}

void IlluminationDifference::logStatistics(const cv::Mat& radiance, LogStatistics& out)
{
  static const cv::Matx13f rec709(0.2126f, 0.7152f, 0.0722f);
  cv::transform(radiance, this->Luminance, rec709);
  // l = log10(max(Y, floor) / floor): zero at the floor, so the signal is non-negative and the
  // data range D is [0, D] as SSIM's luminance term assumes.
  const float floor = this->Params.LuminanceFloor;
  cv::max(this->Luminance, floor, this->Luminance);
  this->Luminance *= 1.0 / floor;
  cv::log(this->Luminance, out.Log);
  out.Log *= 1.0 / std::log(10.0);
  gaussianWindow(out.Log, out.Mean);
  cv::multiply(out.Log, out.Log, this->Scratch);
  gaussianWindow(this->Scratch, out.MeanOfSq);
}

float IlluminationDifference::compare(const LogStatistics& x, const LogStatistics& y)
{
  const double range =
    std::log10(static_cast<double>(this->Params.MaxLuminance) / this->Params.LuminanceFloor);
  const float c1 = static_cast<float>((0.01 * range) * (0.01 * range));
  const float c2 = static_cast<float>((0.03 * range) * (0.03 * range));
  cv::multiply(x.Log, y.Log, this->Product);
  gaussianWindow(this->Product, this->MeanOfProduct);

  // SSIM = (2 mx my + C1)(2 sxy + C2) / ((mx^2 + my^2 + C1)(sx^2 + sy^2 + C2)), Wang et al.
  // (2004) Eq. 13, with the moments from the Gaussian-windowed sums. Written as one pass over
  // the five windowed images (OpenCV expressions would allocate about ten temporaries).
  this->Ssim.create(x.Log.size(), CV_32F);
  for (int r = 0; r < x.Log.rows; ++r)
  {
    const float* mx = x.Mean.ptr<float>(r);
    const float* my = y.Mean.ptr<float>(r);
    const float* sxx = x.MeanOfSq.ptr<float>(r);
    const float* syy = y.MeanOfSq.ptr<float>(r);
    const float* sxy = this->MeanOfProduct.ptr<float>(r);
    float* out = this->Ssim.ptr<float>(r);
    for (int c = 0; c < x.Log.cols; ++c)
    {
      const float mxmy = mx[c] * my[c];
      const float mx2 = mx[c] * mx[c];
      const float my2 = my[c] * my[c];
      const float varX = std::max(sxx[c] - mx2, 0.0f);
      const float varY = std::max(syy[c] - my2, 0.0f);
      const float cov = sxy[c] - mxmy;
      out[c] = ((2.0f * mxmy + c1) * (2.0f * cov + c2)) / ((mx2 + my2 + c1) * (varX + varY + c2));
    }
  }
  // The mean of the SSIM map over each patch; INTER_AREA averages exactly these pixel blocks
  // (with fractional weights where the size is not a multiple of the grid).
  const int n = this->Params.PatchGrid;
  cv::resize(this->Ssim, this->PatchSimilarity, cv::Size(n, n), 0.0, 0.0, cv::INTER_AREA);
  double minSsim = 0.0;
  double maxSsim = 0.0;
  cv::minMaxLoc(this->PatchSimilarity, &minSsim, &maxSsim);
  const double similarity =
    this->Params.Mode == IlluminationDifferenceMode::LeastSimilarPatch ? minSsim : maxSsim;
  const double t = 1.0 - similarity; // SSIM can be negative on log data: clamp
  this->Difference = static_cast<float>(std::clamp(t, 0.0, static_cast<double>(MaxDifference)));
  return this->Difference;
}

float IlluminationDifference::compute(const cv::Mat& previous, const cv::Mat& current)
{
  this->validate(previous, "previous");
  this->validate(current, "current");
  if (previous.size() != current.size())
  {
    throw std::invalid_argument("IlluminationDifference::compute: the two radiance maps differ "
                                "in size; resample them to one resolution first.");
  }
  this->logStatistics(previous, this->Previous);
  this->logStatistics(current, this->Current);
  const float t = this->compare(this->Previous, this->Current);
  // `current` becomes the history, so update() may continue the sequence from it.
  std::swap(this->Previous, this->Current);
  this->HasHistory = true;
  return t;
}

float IlluminationDifference::update(const cv::Mat& radiance)
{
  this->validate(radiance, "current");
  if (this->HasHistory && this->Previous.Log.size() != radiance.size())
  {
    this->HasHistory = false;
  }
  this->logStatistics(radiance, this->Current);
  float t = MaxDifference;
  if (this->HasHistory)
  {
    t = this->compare(this->Previous, this->Current);
  }
  else
  {
    this->Difference = MaxDifference;
    this->PatchSimilarity.release();
  }
  // The statistics of this frame become the history of the next one (buffers are swapped, not
  // copied, so the per-frame path does not allocate once the sizes are settled).
  std::swap(this->Previous, this->Current);
  this->HasHistory = true;
  return t;
}

void IlluminationDifference::reset()
{
  this->HasHistory = false;
  this->Difference = MaxDifference;
  this->PatchSimilarity.release();
}
}
}
