// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/IlluminationDifference.h"

#include "SimdClones.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

// The SSIM pass's row loops (plain arithmetic over rows the caller sized) are left out of
// AddressSanitizer/UBSan builds' instrumentation: instrumented they ran 20 times slower, over the
// budget that IlluminationDifference.SpeedOnOneCore asserts; the tests check their results
// against cv::GaussianBlur.
#if defined(__has_attribute)
#if __has_attribute(no_sanitize)
#define HV_NO_SANITIZE __attribute__((no_sanitize("address", "undefined")))
#endif
#endif
#ifndef HV_NO_SANITIZE
#define HV_NO_SANITIZE
#endif

namespace hv
{
namespace lighting
{
namespace
{
// Wang et al. (2004): 11 x 11 circular-symmetric Gaussian window, sigma = 1.5 samples.
const cv::Size SsimWindow(11, 11);
constexpr double SsimSigma = 1.5;

// One row of the SSIM window's horizontal pass: out[x] = sum_j w[j] in[x + j] for the 11 taps
// (in: the row with 5 reflected samples on either side), the symmetric taps paired.
HV_SIMD_CLONES HV_NO_SANITIZE void windowRow(
  int count, const float* __restrict in, const float* __restrict w, float* __restrict out)
{
  for (int x = 0; x < count; ++x)
  {
    const float* p = in + x;
    out[x] = ((((w[0] * (p[0] + p[10]) + w[1] * (p[1] + p[9])) + w[2] * (p[2] + p[8])) +
                w[3] * (p[3] + p[7])) +
               w[4] * (p[4] + p[6])) +
      w[5] * p[5];
  }
}

// One row of the vertical pass: out[x] = sum_j w[j] rows[j][x] over the 11 rows of the window.
HV_SIMD_CLONES HV_NO_SANITIZE void windowColumn(
  int count, const float* const* rows, const float* __restrict w, float* __restrict out)
{
  const float* __restrict r0 = rows[0];
  const float* __restrict r1 = rows[1];
  const float* __restrict r2 = rows[2];
  const float* __restrict r3 = rows[3];
  const float* __restrict r4 = rows[4];
  const float* __restrict r5 = rows[5];
  const float* __restrict r6 = rows[6];
  const float* __restrict r7 = rows[7];
  const float* __restrict r8 = rows[8];
  const float* __restrict r9 = rows[9];
  const float* __restrict r10 = rows[10];
  for (int x = 0; x < count; ++x)
  {
    out[x] = ((((w[0] * (r0[x] + r10[x]) + w[1] * (r1[x] + r9[x])) + w[2] * (r2[x] + r8[x])) +
                w[3] * (r3[x] + r7[x])) +
               w[4] * (r4[x] + r6[x])) +
      w[5] * r5[x];
  }
}

// The signals whose windowed means SSIM needs, for one row: a, a^2 and, when b is given, a b.
HV_SIMD_CLONES HV_NO_SANITIZE void momentRow(int count, const float* __restrict a,
  const float* __restrict b, float* __restrict first, float* __restrict square,
  float* __restrict product)
{
  for (int x = 0; x < count; ++x)
  {
    first[x] = a[x];
    square[x] = a[x] * a[x];
  }
  if (b)
  {
    for (int x = 0; x < count; ++x)
    {
      product[x] = a[x] * b[x];
    }
  }
}

// sum[x] += row[x]: the SSIM rows of one block row of patches, added up column by column.
HV_SIMD_CLONES HV_NO_SANITIZE void addRow(
  int count, const float* __restrict row, float* __restrict sum)
{
  for (int x = 0; x < count; ++x)
  {
    sum[x] += row[x];
  }
}

// One row of the SSIM map from the Gaussian-windowed moments.
HV_SIMD_CLONES HV_NO_SANITIZE void ssimRow(int count, const float* __restrict mx,
  const float* __restrict my, const float* __restrict sxx, const float* __restrict syy,
  const float* __restrict sxy, float c1, float c2, float* __restrict out)
{
  for (int c = 0; c < count; ++c)
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

// One row of max(Y, floor) / floor, Y = Rec. 709 luminance (as cv::transform computes it);
// false when Y is NaN or infinite. Float bits with an all-ones exponent are exactly the
// non-finite values; the test is an integer OR, so the loop vectorises.
HV_SIMD_CLONES HV_NO_SANITIZE bool flooredLuminanceRow(
  int count, const float* __restrict rgb, float floor, float inverseFloor, float* __restrict out)
{
  std::uint32_t nonFinite = 0;
  for (int i = 0; i < count; ++i)
  {
    const float y = 0.2126f * rgb[3 * i] + 0.7152f * rgb[3 * i + 1] + 0.0722f * rgb[3 * i + 2];
    std::uint32_t bits;
    std::memcpy(&bits, &y, sizeof(bits));
    nonFinite |= (bits & 0x7f800000u) + 0x00800000u; // carries into bit 31 for 0xff exponents
    out[i] = std::max(y, floor) * inverseFloor;
  }
  return (nonFinite & 0x80000000u) == 0;
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

void IlluminationDifference::validate(
  const cv::Mat& radiance, const char* what, bool checkFinite) const
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
  if (checkFinite && !cv::checkRange(radiance))
  {
    throw std::invalid_argument(std::string("IlluminationDifference: the ") + what +
      " radiance map holds NaN or infinite values; fix the radiance estimation upstream.");
  }
}

void IlluminationDifference::logStatistics(
  const cv::Mat& radiance, LogStatistics& out, const LogStatistics* previous)
{
  // l = ln(max(Y, floor) / floor): zero at the floor, so the signal is non-negative and the data
  // range D is [0, D] as SSIM's luminance term assumes. Natural logarithms instead of log10
  // save a pass: scaling l (and D with it, so C1 and C2) by a constant leaves SSIM unchanged.
  // Y is computed by hand in one pass that also checks the map for NaN and infinities: Y is
  // finite exactly when R, G and B are (the weights are positive and sum to 1), and
  // cv::transform plus cv::checkRange took 0.35 ms at 512 x 256, this loop ~0.05 ms.
  const float floor = this->Params.LuminanceFloor;
  const float inverseFloor = static_cast<float>(1.0 / floor);
  out.Log.create(radiance.size(), CV_32F);
  bool finite = true;
  for (int r = 0; r < radiance.rows; ++r)
  {
    finite = flooredLuminanceRow(
               radiance.cols, radiance.ptr<float>(r), floor, inverseFloor, out.Log.ptr<float>(r)) &&
      finite;
  }
  if (!finite)
  {
    throw std::invalid_argument("IlluminationDifference: the current radiance map holds NaN or "
                                "infinite values; fix the radiance estimation upstream.");
  }
  cv::log(out.Log, out.Log); // in place: one image less to go through the cache
  this->windowedMoments(out, previous);
}

void IlluminationDifference::windowedMoments(LogStatistics& y, const LogStatistics* x)
{
  // G * l, G * l^2 and, with the previous frame x, G * (l_x l) with G the SSIM window, as
  // cv::GaussianBlur(SsimWindow, SsimSigma, BORDER_REFLECT) computes them (same weights from
  // cv::getGaussianKernel, same border; sums in another order), in one pass over the frame;
  // each row of the SSIM map is formed as soon as its moments are. Three GaussianBlur calls,
  // two cv::multiply and the SSIM pass took 0.6 ms at 512 x 256 on one core, this ~0.3 ms: the
  // squares and products are formed row by row in the cache instead of as images, the window
  // has a fixed size, and the horizontally filtered rows live in a ring of 11 rows that stays
  // in the cache.
  static const cv::Mat kernel = cv::getGaussianKernel(SsimWindow.width, SsimSigma, CV_32F);
  const float* w = kernel.ptr<float>();
  constexpr int Radius = 5;
  constexpr int Taps = 2 * Radius + 1;
  const cv::Mat& a = y.Log;
  const cv::Mat* b = x ? &x->Log : nullptr;
  const int rows = a.rows;
  const int cols = a.cols;
  const int signals = b ? 3 : 2;
  y.Mean.create(rows, cols, CV_32F);
  y.MeanOfSq.create(rows, cols, CV_32F);
  this->Padded.create(signals + 1, cols + 2 * Radius, CV_32F); // + the product's mean row
  for (int c = 0; c < signals; ++c)
  {
    this->RowWindowed[c].create(Taps, cols, CV_32F);
  }
  float c1 = 0.0f;
  float c2 = 0.0f;
  if (b)
  {
    // D in the units of l (natural logarithms, see logStatistics()).
    const double range =
      std::log(static_cast<double>(this->Params.MaxLuminance) / this->Params.LuminanceFloor);
    c1 = static_cast<float>((0.01 * range) * (0.01 * range));
    c2 = static_cast<float>((0.03 * range) * (0.03 * range));
  }
  // The mean of the SSIM map over each patch. When the grid divides the panorama (as at
  // 512 x 256 and N = 8), the rows of the map are summed per block as they come and the map is
  // never stored; otherwise it is, for cv::resize(INTER_AREA) and its fractional weights.
  const int n = this->Params.PatchGrid;
  const bool blocks = b && rows % n == 0 && cols % n == 0;
  this->PatchesSummed = blocks;
  if (blocks)
  {
    this->PatchSimilarity.create(n, n, CV_32F);
    this->SsimRows.create(2, cols, CV_32F); // one SSIM row, the running sum of the block's rows
    this->SsimRows.row(1).setTo(0.0f);
  }
  else if (b)
  {
    this->Ssim.create(rows, cols, CV_32F);
  }
  // Source row s, filtered horizontally, is kept in ring row s % Taps: an output row needs the
  // source rows within 5 of it (reflected at the edges), which never share a ring row.
  int filteredRows = 0;
  auto filterRow = [&](int r)
  {
    momentRow(cols, a.ptr<float>(r), b ? b->ptr<float>(r) : nullptr,
      this->Padded.ptr<float>(0) + Radius, this->Padded.ptr<float>(1) + Radius,
      b ? this->Padded.ptr<float>(2) + Radius : nullptr);
    for (int c = 0; c < signals; ++c)
    {
      float* padded = this->Padded.ptr<float>(c);
      for (int i = 0; i < Radius; ++i)
      {
        padded[i] = padded[Radius + cv::borderInterpolate(i - Radius, cols, cv::BORDER_REFLECT)];
        padded[Radius + cols + i] =
          padded[Radius + cv::borderInterpolate(cols + i, cols, cv::BORDER_REFLECT)];
      }
      windowRow(cols, padded, w, this->RowWindowed[c].ptr<float>(r % Taps));
    }
  };
  float* meanOfProduct = this->Padded.ptr<float>(signals);
  cv::Mat* outputs[2] = { &y.Mean, &y.MeanOfSq };
  for (int r = 0; r < rows; ++r)
  {
    while (filteredRows < std::min(rows, r + Radius + 1))
    {
      filterRow(filteredRows++);
    }
    int source[Taps];
    for (int j = 0; j < Taps; ++j)
    {
      source[j] = cv::borderInterpolate(r + j - Radius, rows, cv::BORDER_REFLECT) % Taps;
    }
    for (int c = 0; c < signals; ++c)
    {
      const float* window[Taps];
      for (int j = 0; j < Taps; ++j)
      {
        window[j] = this->RowWindowed[c].ptr<float>(source[j]);
      }
      windowColumn(cols, window, w, c < 2 ? outputs[c]->ptr<float>(r) : meanOfProduct);
    }
    if (blocks)
    {
      float* ssim = this->SsimRows.ptr<float>(0);
      float* blockRows = this->SsimRows.ptr<float>(1);
      ssimRow(cols, x->Mean.ptr<float>(r), y.Mean.ptr<float>(r), x->MeanOfSq.ptr<float>(r),
        y.MeanOfSq.ptr<float>(r), meanOfProduct, c1, c2, ssim);
      addRow(cols, ssim, blockRows);
      const int blockHeight = rows / n;
      if ((r + 1) % blockHeight == 0)
      {
        const int blockWidth = cols / n;
        float* patches = this->PatchSimilarity.ptr<float>(r / blockHeight);
        for (int p = 0; p < n; ++p)
        {
          double sum = 0.0;
          for (int i = p * blockWidth; i < (p + 1) * blockWidth; ++i)
          {
            sum += blockRows[i];
          }
          patches[p] = static_cast<float>(sum / (static_cast<double>(blockWidth) * blockHeight));
        }
        std::fill(blockRows, blockRows + cols, 0.0f);
      }
    }
    else if (b)
    {
      ssimRow(cols, x->Mean.ptr<float>(r), y.Mean.ptr<float>(r), x->MeanOfSq.ptr<float>(r),
        y.MeanOfSq.ptr<float>(r), meanOfProduct, c1, c2, this->Ssim.ptr<float>(r));
    }
  }
}

float IlluminationDifference::compare()
{
  // SSIM = (2 mx my + C1)(2 sxy + C2) / ((mx^2 + my^2 + C1)(sx^2 + sy^2 + C2)), Wang et al.
  // (2004) Eq. 13, with the moments from the Gaussian-windowed sums: the map was formed with the
  // current frame's statistics (windowedMoments()).
  // The mean of the SSIM map over each patch, unless windowedMoments() summed the blocks
  // already; INTER_AREA averages exactly these pixel blocks (with fractional weights where the
  // size is not a multiple of the grid).
  const int n = this->Params.PatchGrid;
  if (!this->PatchesSummed)
  {
    cv::resize(this->Ssim, this->PatchSimilarity, cv::Size(n, n), 0.0, 0.0, cv::INTER_AREA);
  }
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
  // Both maps are checked before either is used, so that a bad map leaves the history as it
  // was.
  this->validate(previous, "previous", true);
  this->validate(current, "current", true);
  if (previous.size() != current.size())
  {
    throw std::invalid_argument("IlluminationDifference::compute: the two radiance maps differ "
                                "in size; resample them to one resolution first.");
  }
  this->logStatistics(previous, this->Previous, nullptr);
  this->logStatistics(current, this->Current, &this->Previous);
  const float t = this->compare();
  // `current` becomes the history, so update() may continue the sequence from it.
  std::swap(this->Previous, this->Current);
  this->HasHistory = true;
  return t;
}

float IlluminationDifference::update(const cv::Mat& radiance)
{
  // NaN and infinities are found by logStatistics(), which writes only Current: on bad input
  // the history stays as it was.
  this->validate(radiance, "current", false);
  const bool comparable = this->HasHistory && this->Previous.Log.size() == radiance.size();
  this->logStatistics(radiance, this->Current, comparable ? &this->Previous : nullptr);
  this->HasHistory = comparable;
  float t = MaxDifference;
  if (this->HasHistory)
  {
    t = this->compare();
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
