// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/LightSourceEstimator.h"

#include "hv/Equirectangular.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

namespace hv
{
namespace lighting
{
namespace
{
constexpr double DegreesToRadians = 3.14159265358979323846 / 180.0;
// A region whose pixels reach further than this from its centre is an over-exposed area (a
// bright sky, a white wall), not a light; it keeps its observed values.
constexpr double MaxLightRadius = 60.0 * DegreesToRadians;
// The tangent patch of one light is at most about this many pixels across; larger lights are
// modelled on a coarser patch.
constexpr int MaxPatchSize = 64;

float rec709(float r, float g, float b)
{
  return 0.2126f * r + 0.7152f * g + 0.0722f * b;
}

int findRoot(std::vector<int>& parent, int i)
{
  while (parent[i] != i)
  {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

void unite(std::vector<int>& parent, int a, int b)
{
  a = findRoot(parent, a);
  b = findRoot(parent, b);
  if (a != b)
  {
    parent[std::max(a, b)] = std::min(a, b);
  }
}

// Where (x, y) falls in a cols x rows patch, for repeated bilinear lookups.
template <typename T>
T bilinearAt(int cols, int rows, float x, float y)
{
  T b;
  if (!(x >= 0.0f && y >= 0.0f && x <= cols - 1.0f && y <= rows - 1.0f))
  {
    b.Index = -1;
    return b;
  }
  const int x0 = std::min(static_cast<int>(x), cols - 2);
  const int y0 = std::min(static_cast<int>(y), rows - 2);
  b.Index = y0 * cols + x0;
  b.Fx = x - static_cast<float>(x0);
  b.Fy = y - static_cast<float>(y0);
  return b;
}

template <typename T>
float lookup(const cv::Mat& patch, const T& b)
{
  if (b.Index < 0)
  {
    return 0.0f;
  }
  const float* p = patch.ptr<float>() + b.Index;
  const float* q = p + patch.cols;
  return (1.0f - b.Fy) * ((1.0f - b.Fx) * p[0] + b.Fx * p[1]) +
    b.Fy * ((1.0f - b.Fx) * q[0] + b.Fx * q[1]);
}

void requireRange(bool ok, const char* message)
{
  if (!ok)
  {
    throw std::invalid_argument(std::string("LightSourceEstimator: ") + message);
  }
}
}

void expandLandis(const cv::Mat& linear, cv::Mat& expanded, float clipLevel, float threshold,
  float exponent, float maxRadiance)
{
  if (linear.empty() || linear.type() != CV_32FC3)
  {
    throw std::invalid_argument("expandLandis: expected a non-empty CV_32FC3 image.");
  }
  if (!(clipLevel > 0.0f) || !(threshold >= 0.0f && threshold < 1.0f) || !(exponent > 0.0f) ||
    !(maxRadiance >= 1.0f))
  {
    throw std::invalid_argument("expandLandis: need clipLevel > 0, 0 <= threshold < 1, "
                                "exponent > 0 and maxRadiance >= 1.");
  }
  linear.copyTo(expanded);
  float yMax = 0.0f;
  for (int y = 0; y < linear.rows; ++y)
  {
    const float* p = linear.ptr<float>(y);
    for (int x = 0; x < linear.cols; ++x, p += 3)
    {
      yMax = std::max(yMax, rec709(p[0], p[1], p[2]) / clipLevel);
    }
  }
  if (!(yMax > threshold))
  {
    return;
  }
  for (int y = 0; y < expanded.rows; ++y)
  {
    float* p = expanded.ptr<float>(y);
    for (int x = 0; x < expanded.cols; ++x, p += 3)
    {
      const float lum = rec709(p[0], p[1], p[2]) / clipLevel;
      if (lum < threshold || !(lum > 0.0f))
      {
        continue;
      }
      // Landis (2002), as in Banterle et al.'s HDR Toolbox (LandisEO).
      const float k = std::pow((lum - threshold) / (yMax - threshold), exponent);
      const float gain = (1.0f - k) + maxRadiance * k;
      p[0] *= gain;
      p[1] *= gain;
      p[2] *= gain;
    }
  }
}

LightSourceEstimator::LightSourceEstimator(const Parameters& parameters)
{
  this->setParameters(parameters);
}

void LightSourceEstimator::setParameters(const Parameters& p)
{
  requireRange(p.ClipLevel > 0.0f && std::isfinite(p.ClipLevel),
    "ClipLevel (the linear value the sensor clips at) must be positive.");
  requireRange(p.NearClipFraction > 0.0f && p.NearClipFraction <= 1.0f,
    "NearClipFraction must lie in (0, 1] (0.95: sRGB code 250).");
  requireRange(p.ThresholdMads >= 0.0f && std::isfinite(p.ThresholdMads) &&
      p.HdrThresholdMads >= 0.0f && std::isfinite(p.HdrThresholdMads),
    "ThresholdMads and HdrThresholdMads (k in median + k MAD) must be non-negative.");
  requireRange(p.MinPixelCount >= 1, "MinPixelCount must be at least 1.");
  requireRange(p.MinPeakFraction >= 0.0f && p.MinPeakFraction <= 1.0f,
    "MinPeakFraction must lie in [0, 1] (0 keeps every region).");
  requireRange(p.MaxFittedLights >= 0, "MaxFittedLights must not be negative.");
  requireRange(p.PsfSigmaDegrees > 0.0f && p.PsfSigmaDegrees <= 10.0f,
    "PsfSigmaDegrees must lie in (0, 10] degrees.");
  requireRange(p.HaloFraction >= 0.0f && p.HaloFraction <= 0.5f,
    "HaloFraction (share of the light's energy in the glare halo) must lie in [0, 0.5].");
  requireRange(p.HaloFraction == 0.0f ||
      (p.HaloSigmaDegrees > p.PsfSigmaDegrees && p.HaloSigmaDegrees <= 30.0f),
    "HaloSigmaDegrees must exceed PsfSigmaDegrees and be at most 30 degrees.");
  requireRange(p.MinExplainedFraction >= 0.0f && p.MinExplainedFraction <= 1.0f,
    "MinExplainedFraction must lie in [0, 1].");
  requireRange(p.MaxRadiance > p.ClipLevel && std::isfinite(p.MaxRadiance),
    "MaxRadiance must be finite and above ClipLevel.");
  requireRange(
    p.LandisThreshold >= 0.0f && p.LandisThreshold < 1.0f, "LandisThreshold must lie in [0, 1).");
  requireRange(p.LandisExponent > 0.0f, "LandisExponent must be positive.");
  requireRange(p.LandisMaxRadiance >= 1.0f, "LandisMaxRadiance must be at least 1.");
  this->Params = p;
}

void LightSourceEstimator::validate(const cv::Mat& linear, const cv::Mat& mask) const
{
  if (linear.empty())
  {
    throw std::invalid_argument("LightSourceEstimator: the panorama is empty.");
  }
  if (linear.type() != CV_32FC3)
  {
    throw std::invalid_argument("LightSourceEstimator: expected a CV_32FC3 linear RGB panorama, "
                                "got " +
      cv::typeToString(linear.type()) + "; linearise 8/16-bit frames with CameraResponse first.");
  }
  if (linear.cols != 2 * linear.rows || linear.rows < 8)
  {
    throw std::invalid_argument("LightSourceEstimator: the panorama is " +
      std::to_string(linear.cols) + "x" + std::to_string(linear.rows) +
      "; an equirectangular panorama is twice as wide as high (at least 16x8).");
  }
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != linear.size()))
  {
    throw std::invalid_argument("LightSourceEstimator: the saturation mask must be empty or a "
                                "CV_8UC1 image of the panorama's size.");
  }
}

void LightSourceEstimator::prepareGeometry(int width, int height)
{
  if (width == this->Width && height == this->Height)
  {
    return;
  }
  this->Width = width;
  this->Height = height;
  this->RowSolidAngle.resize(height);
  this->SinTheta.resize(height);
  this->CosTheta.resize(height);
  this->SinPhi.resize(width);
  this->CosPhi.resize(width);
  const double dPhi = 2.0 * Pi / width;
  for (int y = 0; y < height; ++y)
  {
    const double theta0 = Pi * y / height;
    const double theta1 = Pi * (y + 1) / height;
    const double theta = Pi * (y + 0.5) / height;
    // Exact solid angle of a pixel row: (cos theta0 - cos theta1) dphi.
    this->RowSolidAngle[y] = static_cast<float>((std::cos(theta0) - std::cos(theta1)) * dPhi);
    this->SinTheta[y] = static_cast<float>(std::sin(theta));
    this->CosTheta[y] = static_cast<float>(std::cos(theta));
  }
  for (int x = 0; x < width; ++x)
  {
    const double phi = ((x + 0.5) / width - 0.5) * 2.0 * Pi;
    this->SinPhi[x] = static_cast<float>(std::sin(phi));
    this->CosPhi[x] = static_cast<float>(std::cos(phi));
  }
}

void LightSourceEstimator::computeBrightness(const cv::Mat& linear)
{
  this->Luminance.create(linear.size(), CV_32F);
  this->Brightness.create(linear.size(), CV_32F);
  for (int y = 0; y < linear.rows; ++y)
  {
    const float* p = linear.ptr<float>(y);
    float* lum = this->Luminance.ptr<float>(y);
    float* bright = this->Brightness.ptr<float>(y);
    for (int x = 0; x < linear.cols; ++x, p += 3)
    {
      if (!std::isfinite(p[0] + p[1] + p[2]))
      {
        throw std::invalid_argument("LightSourceEstimator: the panorama holds NaN or infinite "
                                    "values; replace them (e.g. cv::patchNaNs) before "
                                    "estimating.");
      }
      // Negative values (float noise of some HDR encoders) count as 0.
      const float r = std::max(p[0], 0.0f);
      const float g = std::max(p[1], 0.0f);
      const float b = std::max(p[2], 0.0f);
      lum[x] = rec709(r, g, b);
      bright[x] = std::max(r, std::max(g, b));
    }
  }
}

float LightSourceEstimator::statisticalThreshold(float mads)
{
  // Median and median absolute deviation of ln B on a regular subsample (about 8000 pixels):
  // robust to the lights themselves, which are a small fraction of the sphere.
  const int stride = std::max(1, this->Height / 64);
  this->LogSamples.clear();
  for (int y = stride / 2; y < this->Height; y += stride)
  {
    const float* bright = this->Brightness.ptr<float>(y);
    for (int x = stride / 2; x < this->Width; x += stride)
    {
      this->LogSamples.push_back(std::log(std::max(bright[x], 1e-6f)));
    }
  }
  auto& s = this->LogSamples;
  const auto mid = s.begin() + static_cast<std::ptrdiff_t>(s.size() / 2);
  std::nth_element(s.begin(), mid, s.end());
  const float median = *mid;
  for (float& v : s)
  {
    v = std::abs(v - median);
  }
  std::nth_element(s.begin(), mid, s.end());
  const float mad = *mid;
  return std::exp(median + mads * 1.4826f * mad);
}

void LightSourceEstimator::findRegions(
  const cv::Mat& candidates, const cv::Mat& mask, float minPeak)
{
  // Without statistics: connectedComponentsWithStats took 0.8 ms at 512 x 256 here, the
  // labelling alone 0.08 ms; the areas are counted below.
  const int n = cv::connectedComponents(candidates, this->ComponentLabels, 8, CV_32S);
  this->Parent.resize(n);
  std::iota(this->Parent.begin(), this->Parent.end(), 0);
  const int w = this->Width;
  const int h = this->Height;
  // connectedComponents sees a flat image: the u = 0 / u = 1 seam and the poles (every pixel of
  // the first and last rows touches the pole) are joined here with a union-find over labels.
  for (int y = 0; y < h; ++y)
  {
    const int a = this->ComponentLabels.at<int>(y, 0);
    if (a == 0)
    {
      continue;
    }
    for (int yy = std::max(0, y - 1); yy <= std::min(h - 1, y + 1); ++yy)
    {
      const int b = this->ComponentLabels.at<int>(yy, w - 1);
      if (b != 0)
      {
        unite(this->Parent, a, b);
      }
    }
  }
  for (const int row : { 0, h - 1 })
  {
    int first = 0;
    for (int x = 0; x < w; ++x)
    {
      const int a = this->ComponentLabels.at<int>(row, x);
      if (a != 0)
      {
        if (first == 0)
        {
          first = a;
        }
        unite(this->Parent, first, a);
      }
    }
  }
  std::vector<int>& rootArea = this->RootArea;
  rootArea.assign(n, 0);
  for (int y = 0; y < h; ++y)
  {
    const int* label = this->ComponentLabels.ptr<int>(y);
    for (int x = 0; x < w; ++x)
    {
      ++rootArea[label[x]];
    }
  }
  for (int i = 1; i < n; ++i)
  {
    const int root = findRoot(this->Parent, i);
    if (root != i)
    {
      rootArea[root] += rootArea[i];
    }
  }
  std::vector<int>& regionOfRoot = this->RegionOfRoot;
  regionOfRoot.assign(n, -1);
  int regions = 0;
  for (int i = 1; i < n; ++i)
  {
    if (findRoot(this->Parent, i) == i && rootArea[i] >= this->Params.MinPixelCount)
    {
      regionOfRoot[i] = regions++;
    }
  }
  this->Regions.resize(regions);
  for (int r = 0; r < regions; ++r)
  {
    this->Regions[r].Pixels.clear();
    this->Regions[r].Clipped = false;
    this->Regions[r].Peak = 0.0f;
  }
  std::vector<int>& regionOfLabel = this->RegionOfLabel;
  regionOfLabel.assign(n, -1);
  for (int i = 1; i < n; ++i)
  {
    regionOfLabel[i] = regionOfRoot[findRoot(this->Parent, i)];
  }
  const float nearClip = this->Params.NearClipFraction * this->Params.ClipLevel;
  this->Labels.create(h, w, CV_32S);
  this->Labels.setTo(0);
  for (int y = 0; y < h; ++y)
  {
    const int* label = this->ComponentLabels.ptr<int>(y);
    const float* bright = this->Brightness.ptr<float>(y);
    const uchar* m = mask.empty() ? nullptr : mask.ptr<uchar>(y);
    int* out = this->Labels.ptr<int>(y);
    for (int x = 0; x < w; ++x)
    {
      const int r = label[x] == 0 ? -1 : regionOfLabel[label[x]];
      if (r < 0)
      {
        continue;
      }
      Region& region = this->Regions[r];
      region.Pixels.push_back(y * w + x);
      region.Clipped = region.Clipped || bright[x] >= nearClip || (m && m[x] != 0);
      region.Peak = std::max(region.Peak, bright[x]);
      out[x] = r + 1;
    }
  }
  // Sensor noise on a surface just below the clip level pushes pixels over the near-clip
  // threshold, but seldom to the top codes, which the core of a real light reaches: regions
  // that never get there are dropped (measured at 512 x 256: a flat wall at sRGB code 245 with
  // noise of 2 code values gave 1439 regions, 12 of which reach code 253).
  if (minPeak > 0.0f)
  {
    int kept = 0;
    for (int r = 0; r < regions; ++r)
    {
      Region& region = this->Regions[r];
      if (region.Peak < minPeak)
      {
        for (const int pixel : region.Pixels)
        {
          this->Labels.at<int>(pixel / w, pixel % w) = 0;
        }
        continue;
      }
      if (kept != r)
      {
        std::swap(this->Regions[kept], region);
        for (const int pixel : this->Regions[kept].Pixels)
        {
          this->Labels.at<int>(pixel / w, pixel % w) = kept + 1;
        }
      }
      ++kept;
    }
    this->Regions.resize(kept);
  }
}

void LightSourceEstimator::describe(
  const cv::Mat& q, const Region& region, DetectedLight& light) const
{
  const int w = this->Width;
  double omega = 0.0;
  double rgb[3] = { 0.0, 0.0, 0.0 };
  double peak = 0.0;
  glm::dvec3 weighted(0.0);
  glm::dvec3 geometric(0.0);
  int yMin = this->Height;
  int yMax = -1;
  std::vector<char> columns(w, 0);
  for (const int p : region.Pixels)
  {
    const int x = p % w;
    const int y = p / w;
    const cv::Vec3f v = q.at<cv::Vec3f>(y, x);
    const double dOmega = this->RowSolidAngle[y];
    const double lum = rec709(v[0], v[1], v[2]);
    const glm::dvec3 d(
      this->SinTheta[y] * this->SinPhi[x], this->CosTheta[y], -this->SinTheta[y] * this->CosPhi[x]);
    omega += dOmega;
    for (int c = 0; c < 3; ++c)
    {
      rgb[c] += v[c] * dOmega;
    }
    peak = std::max(peak, lum);
    weighted += std::max(lum, 0.0) * dOmega * d;
    geometric += dOmega * d;
    yMin = std::min(yMin, y);
    yMax = std::max(yMax, y);
    columns[x] = 1;
  }
  light = DetectedLight();
  light.PixelCount = static_cast<int>(region.Pixels.size());
  light.SolidAngle = static_cast<float>(omega);
  light.Clipped = region.Clipped;
  const glm::dvec3 centre = glm::length(weighted) > 0.0 ? weighted : geometric;
  if (glm::length(centre) > 0.0)
  {
    light.Direction = glm::vec3(glm::normalize(centre));
  }
  if (omega > 0.0)
  {
    light.Radiance = glm::vec3(static_cast<float>(rgb[0] / omega),
      static_cast<float>(rgb[1] / omega), static_cast<float>(rgb[2] / omega));
  }
  light.Intensity = hv::luminance(light.Radiance);
  light.Colour = light.Intensity > 0.0f ? light.Radiance / light.Intensity : glm::vec3(1.0f);
  light.Peak = static_cast<float>(peak);
  light.Power = static_cast<float>(hv::luminance(
    glm::vec3(static_cast<float>(rgb[0]), static_cast<float>(rgb[1]), static_cast<float>(rgb[2]))));
  light.SourceRadiance = light.Intensity;
  light.SourceSolidAngle = light.SolidAngle;
  // Bounding box across the seam: the columns not covered form gaps; the box starts after the
  // longest gap (circularly) and may run past the right edge.
  int bestGap = 0;
  int bestGapEnd = 0;
  int run = 0;
  for (int i = 0; i < 2 * w; ++i)
  {
    if (columns[i % w] == 0)
    {
      ++run;
      if (run > bestGap && run <= w)
      {
        bestGap = run;
        bestGapEnd = i % w;
      }
    }
    else
    {
      run = 0;
    }
  }
  const int x0 = bestGap == 0 ? 0 : (bestGapEnd + 1) % w;
  light.BoundingBox = cv::Rect(x0, yMin, w - bestGap, yMax - yMin + 1);
}

float LightSourceEstimator::evaluateSupport(
  float delta, float& radiance, double background[3], double& residual)
{
  const Parameters& p = this->Params;
  const double pitch = Pi / this->Height;
  const double coreSigma =
    std::sqrt(std::pow(p.PsfSigmaDegrees * DegreesToRadians, 2.0) + pitch * pitch / 12.0) /
    this->PatchPitch;
  const double haloSigma = p.HaloSigmaDegrees * DegreesToRadians / this->PatchPitch;

  // S_delta = clamp(SD - delta + 1/2, 0, 1): the clipped region eroded by delta patch pixels,
  // with partial coverage of the boundary pixels so that S varies continuously with delta.
  cv::add(this->SignedDistance, cv::Scalar(0.5 - delta), this->Support);
  cv::threshold(this->Support, this->Support, 1.0, 1.0, cv::THRESH_TRUNC);
  cv::threshold(this->Support, this->Support, 0.0, 0.0, cv::THRESH_TOZERO);
  cv::GaussianBlur(
    this->Support, this->CoreBlur, cv::Size(0, 0), coreSigma, coreSigma, cv::BORDER_CONSTANT);
  const float halo = p.HaloFraction;
  if (halo > 0.0f)
  {
    // The halo is smooth (sigma of several patch pixels): blurring a box-averaged, f-times
    // coarser support is as accurate and f^3 times cheaper. The box average itself adds a
    // variance of (f^2 - 1) / 12 fine pixels^2, which is taken off the Gaussian's.
    const int f = this->HaloFactor;
    const double coarseSigma =
      std::sqrt(std::max(haloSigma * haloSigma - (f * f - 1) / 12.0, 0.25 * f * f)) / f;
    if (f > 1)
    {
      cv::resize(this->Support, this->HaloSupport,
        cv::Size(this->Support.cols / f, this->Support.rows / f), 0.0, 0.0, cv::INTER_AREA);
    }
    else
    {
      this->Support.copyTo(this->HaloSupport);
    }
    cv::GaussianBlur(this->HaloSupport, this->HaloBlur, cv::Size(0, 0), coarseSigma, coarseSigma,
      cv::BORDER_CONSTANT);
  }

  // Linear least squares for Y = b0 + b1 X + b2 Y' + L B over the fitted samples. The
  // background's part of the normal equations does not depend on delta (precomputed in
  // fitLight); only the sums involving B are accumulated here.
  double sumB = 0.0, sumXB = 0.0, sumYB = 0.0, sumBB = 0.0, sumBLum = 0.0;
  double maxModel = 0.0;
  const int count = static_cast<int>(this->Samples.size());
  for (int i = 0; i < count; ++i)
  {
    Sample& s = this->Samples[i];
    s.Model = (1.0f - halo) * lookup(this->CoreBlur, s.Fine);
    if (halo > 0.0f)
    {
      s.Model += halo * lookup(this->HaloBlur, s.Coarse);
    }
    maxModel = std::max(maxModel, static_cast<double>(s.Model));
    if (i < this->FitEnd)
    {
      const double b = s.Model;
      sumB += b;
      sumXB += s.TangentX * b;
      sumYB += s.TangentY * b;
      sumBB += b * b;
      sumBLum += b * s.Luminance;
    }
  }
  if (!(maxModel > 1e-6))
  {
    residual = std::numeric_limits<double>::infinity();
    return 0.0f;
  }
  cv::Matx44d a;
  cv::Vec4d rhs;
  for (int i = 0; i < 3; ++i)
  {
    for (int j = 0; j < 3; ++j)
    {
      a(i, j) = this->BackgroundNormal(i, j);
    }
    rhs[i] = this->BackgroundRhs[i];
  }
  a(0, 3) = a(3, 0) = sumB;
  a(1, 3) = a(3, 1) = sumXB;
  a(2, 3) = a(3, 2) = sumYB;
  a(3, 3) = sumBB;
  rhs[3] = sumBLum;
  cv::Vec4d beta;
  if (!cv::solve(a, rhs, beta, cv::DECOMP_CHOLESKY))
  {
    cv::solve(a, rhs, beta, cv::DECOMP_SVD);
  }
  double l = beta[3];
  // Every clipped sample is at least as bright as observed: L >= (Y_obs - bg) / B.
  double lMin = 0.0;
  for (int i = this->FitEnd; i < this->ConstraintEnd; ++i)
  {
    const Sample& s = this->Samples[i];
    if (s.Model > 1e-4f)
    {
      const double bg = beta[0] + beta[1] * s.TangentX + beta[2] * s.TangentY;
      lMin = std::max(lMin, (s.Luminance - bg) / s.Model);
    }
  }
  const double lBounded = std::clamp(l, lMin, static_cast<double>(p.MaxRadiance));
  if (lBounded != l)
  {
    // Refit the background plane with L fixed.
    l = lBounded;
    const cv::Vec3d rhs3(this->BackgroundRhs[0] - l * sumB, this->BackgroundRhs[1] - l * sumXB,
      this->BackgroundRhs[2] - l * sumYB);
    cv::Vec3d plane;
    if (!cv::solve(this->BackgroundNormal, rhs3, plane, cv::DECOMP_CHOLESKY))
    {
      cv::solve(this->BackgroundNormal, rhs3, plane, cv::DECOMP_SVD);
    }
    beta = cv::Vec4d(plane[0], plane[1], plane[2], l);
  }
  // Sum of squared residuals from the normal equations: sum Y^2 - 2 beta.r + beta^T A beta.
  residual = std::max(0.0, this->SumLuminanceSq - 2.0 * beta.dot(rhs) + beta.dot(a * beta));
  radiance = static_cast<float>(l);
  for (int i = 0; i < 3; ++i)
  {
    background[i] = beta[i];
  }
  return radiance;
}

bool LightSourceEstimator::fitLight(
  const cv::Mat& linear, const cv::Mat& mask, int index, cv::Mat& q, DetectedLight& light)
{
  const Parameters& p = this->Params;
  const Region& region = this->Regions[index];
  const int w = this->Width;
  const int h = this->Height;
  auto direction = [this](int x, int y)
  {
    return glm::dvec3(
      this->SinTheta[y] * this->SinPhi[x], this->CosTheta[y], -this->SinTheta[y] * this->CosPhi[x]);
  };

  glm::dvec3 sum(0.0);
  for (const int pixel : region.Pixels)
  {
    sum += static_cast<double>(this->RowSolidAngle[pixel / w]) * direction(pixel % w, pixel / w);
  }
  if (!(glm::length(sum) > 1e-12))
  {
    return false;
  }
  const glm::dvec3 c0 = glm::normalize(sum);
  double coreRadius = 0.0;
  for (const int pixel : region.Pixels)
  {
    const double cosRho = glm::clamp(glm::dot(direction(pixel % w, pixel / w), c0), -1.0, 1.0);
    coreRadius = std::max(coreRadius, std::acos(cosRho));
  }
  const double pitch = Pi / h;
  coreRadius += pitch;
  if (coreRadius > MaxLightRadius)
  {
    return false;
  }
  const double coreSigma =
    std::sqrt(std::pow(p.PsfSigmaDegrees * DegreesToRadians, 2.0) + pitch * pitch / 12.0);
  const double margin =
    1.5 * (p.HaloFraction > 0.0f ? p.HaloSigmaDegrees * DegreesToRadians : coreSigma) + 2.0 * pitch;
  const double window = std::min(coreRadius + margin, 85.0 * DegreesToRadians);
  this->PatchPitch = static_cast<float>(std::max(pitch, 2.0 * window / (MaxPatchSize - 3)));
  const double patchPitch = this->PatchPitch;
  const int half = static_cast<int>(std::ceil(window / patchPitch)) + 1;
  const double haloSigmaPixels = p.HaloSigmaDegrees * DegreesToRadians / patchPitch;
  this->HaloFactor = std::max(1, static_cast<int>(haloSigmaPixels / 2.0));
  const int f = this->HaloFactor;
  this->PatchSize = (2 * half + 1 + f - 1) / f * f; // a multiple of the halo's coarsening
  const int k = this->PatchSize;
  const double centre = half;

  // Tangent frame at the light: azimuthal-equidistant coordinates (rho cos psi, rho sin psi)
  // keep angular distances from the centre exact, so the isotropic PSF is isotropic on the
  // patch wherever the light is (seam and poles included).
  const glm::dvec3 helper =
    std::abs(c0.y) < 0.9 ? glm::dvec3(0.0, 1.0, 0.0) : glm::dvec3(1.0, 0.0, 0.0);
  const glm::dvec3 e1 = glm::normalize(glm::cross(helper, c0));
  const glm::dvec3 e2 = glm::cross(c0, e1);

  // The clipped region rasterised on the patch (nearest panorama pixel of each patch pixel).
  this->CoreMask.create(k, k, CV_8U);
  this->CoreMask.setTo(0);
  const double rasterRadius = coreRadius + patchPitch;
  for (int i = 0; i < k; ++i)
  {
    uchar* row = this->CoreMask.ptr<uchar>(i);
    for (int j = 0; j < k; ++j)
    {
      const double x = (j - centre) * patchPitch;
      const double y = (i - centre) * patchPitch;
      const double rho = std::hypot(x, y);
      if (rho > rasterRadius)
      {
        continue;
      }
      const glm::dvec3 d =
        rho > 0.0 ? std::cos(rho) * c0 + (std::sin(rho) / rho) * (x * e1 + y * e2) : c0;
      const glm::vec2 uv = hv::directionToEquirectangular(glm::vec3(d));
      const int px = std::min(static_cast<int>(uv.x * w), w - 1);
      const int py = std::min(static_cast<int>(uv.y * h), h - 1);
      if (this->Labels.at<int>(py, px) == index + 1)
      {
        row[j] = 255;
      }
    }
  }
  if (cv::countNonZero(this->CoreMask) == 0)
  {
    return false;
  }
  // Signed distance to the region's boundary (patch pixels, > 0 inside).
  cv::distanceTransform(this->CoreMask, this->InsideDistance, cv::DIST_L2, cv::DIST_MASK_5);
  cv::bitwise_not(this->CoreMask, this->CoreMask);
  cv::distanceTransform(this->CoreMask, this->OutsideDistance, cv::DIST_L2, cv::DIST_MASK_5);
  this->SignedDistance.create(k, k, CV_32F);
  float maxDepth = 0.0f;
  for (int i = 0; i < k; ++i)
  {
    const float* in = this->InsideDistance.ptr<float>(i);
    const float* out = this->OutsideDistance.ptr<float>(i);
    float* sd = this->SignedDistance.ptr<float>(i);
    for (int j = 0; j < k; ++j)
    {
      sd[j] = in[j] > 0.0f ? in[j] - 0.5f : 0.5f - out[j];
      maxDepth = std::max(maxDepth, sd[j]);
    }
  }

  // Panorama pixels within the window, each with its tangent position.
  this->Samples.clear();
  const float nearClip = p.NearClipFraction * p.ClipLevel;
  const double thetaC = std::acos(glm::clamp(c0.y, -1.0, 1.0));
  const double cosWindow = std::cos(window);
  const int y0 = std::max(0, static_cast<int>(std::floor((thetaC - window) / Pi * h)));
  const int y1 = std::min(h - 1, static_cast<int>(std::ceil((thetaC + window) / Pi * h)));
  const bool aroundPole = thetaC - window <= 0.0 || thetaC + window >= Pi;
  const double uC = hv::directionToEquirectangular(glm::vec3(c0)).x;
  const double inversePitch = 1.0 / patchPitch;
  const float inverseFactor = 1.0f / static_cast<float>(f);
  int freeCount = 0;
  for (int y = y0; y <= y1; ++y)
  {
    int xFirst = 0;
    int xCount = w;
    if (!aroundPole)
    {
      // Longitudes within the window on this row (spherical law of cosines).
      const double sinT = this->SinTheta[y];
      const double r = (cosWindow - this->CosTheta[y] * std::cos(thetaC)) /
        std::max(1e-12, sinT * std::sin(thetaC));
      if (r > 1.0)
      {
        continue;
      }
      if (r > -1.0)
      {
        const double halfSpan = std::acos(r) / (2.0 * Pi) * w + 1.0;
        xFirst = static_cast<int>(std::floor(uC * w - 0.5 - halfSpan));
        xCount = std::min(w, static_cast<int>(std::ceil(2.0 * halfSpan)) + 2);
      }
    }
    const uchar* m = mask.empty() ? nullptr : mask.ptr<uchar>(y);
    for (int i = 0; i < xCount; ++i)
    {
      const int x = ((xFirst + i) % w + w) % w;
      const int label = this->Labels.at<int>(y, x);
      int kind = 0;
      if (label == index + 1)
      {
        kind = 1;
      }
      else if (label != 0 || this->Brightness.at<float>(y, x) >= nearClip || (m && m[x] != 0))
      {
        continue; // clipped, but not this light: no information about it
      }
      const glm::dvec3 d = direction(x, y);
      const double cosRho = glm::dot(d, c0);
      if (cosRho < cosWindow)
      {
        continue;
      }
      const double rho = std::acos(std::min(cosRho, 1.0));
      const double t1 = glm::dot(d, e1);
      const double t2 = glm::dot(d, e2);
      const double norm = std::sqrt(t1 * t1 + t2 * t2);
      const double scale = norm > 1e-12 ? rho / norm : 0.0;
      Sample s;
      s.TangentX = static_cast<float>(t1 * scale);
      s.TangentY = static_cast<float>(t2 * scale);
      s.PatchX = static_cast<float>(s.TangentX * inversePitch + centre);
      s.PatchY = static_cast<float>(s.TangentY * inversePitch + centre);
      s.Fine = bilinearAt<Bilinear>(k, k, s.PatchX, s.PatchY);
      // Coarse pixel i averages fine pixels [i f, (i + 1) f): its centre is at i f + (f - 1)/2.
      s.Coarse = bilinearAt<Bilinear>(k / f, k / f, (s.PatchX - 0.5f * (f - 1)) * inverseFactor,
        (s.PatchY - 0.5f * (f - 1)) * inverseFactor);
      s.Luminance = this->Luminance.at<float>(y, x);
      s.Model = 0.0f;
      s.Pixel = y * w + x;
      s.Kind = kind;
      freeCount += kind == 0 ? 1 : 0;
      this->Samples.push_back(s);
    }
  }
  // Samples within a guard band of the region's boundary (2 core sigmas + 1/2 pixel) do not
  // enter the fit: there the model is the far tail of the core PSF, which multiplies the
  // +-1/2-pixel raster error of the boundary into errors of a factor of several (measured: it
  // drove the fit to point-like sources with 3-4x the true power). The halo further out and the
  // region's interior carry the information.
  const double coreSigmaPixels = coreSigma / patchPitch;
  const float guard = static_cast<float>(std::max(1.0, 2.0 * coreSigmaPixels) + 0.5);
  freeCount = 0;
  for (Sample& s : this->Samples)
  {
    const float depth = lookup(this->SignedDistance, s.Fine);
    if (s.Kind == 0 && depth > -guard)
    {
      s.Kind = 3; // near the boundary outside: not fitted
    }
    else if (s.Kind == 1 && depth < guard)
    {
      s.Kind = 4; // near the boundary inside: part of the light, not a constraint
    }
    freeCount += s.Kind == 0 ? 1 : 0;
  }
  if (freeCount < 16)
  {
    return false;
  }
  // Order: fitted samples, then constraints, then the rest of the region; the guard band
  // outside is dropped.
  this->Samples.erase(std::remove_if(this->Samples.begin(), this->Samples.end(),
                        [](const Sample& s) { return s.Kind == 3; }),
    this->Samples.end());
  const auto constraints = std::partition(
    this->Samples.begin(), this->Samples.end(), [](const Sample& s) { return s.Kind == 0; });
  std::partition(constraints, this->Samples.end(), [](const Sample& s) { return s.Kind == 1; });
  this->FitEnd = freeCount;
  this->ConstraintEnd = freeCount;
  while (this->ConstraintEnd < static_cast<int>(this->Samples.size()) &&
    this->Samples[this->ConstraintEnd].Kind == 1)
  {
    ++this->ConstraintEnd;
  }
  this->BackgroundNormal = cv::Matx33d::zeros();
  this->BackgroundRhs = cv::Vec3d::all(0.0);
  this->SumLuminanceSq = 0.0;
  for (int i = 0; i < this->FitEnd; ++i)
  {
    const Sample& s = this->Samples[i];
    const double row[3] = { 1.0, s.TangentX, s.TangentY };
    for (int r = 0; r < 3; ++r)
    {
      for (int c = 0; c < 3; ++c)
      {
        this->BackgroundNormal(r, c) += row[r] * row[c];
      }
      this->BackgroundRhs[r] += row[r] * s.Luminance;
    }
    this->SumLuminanceSq += static_cast<double>(s.Luminance) * s.Luminance;
  }

  // Model check (below): the light model must explain most of the structure of the unclipped
  // surroundings that a background plane alone leaves. Synthetic lights seen through the
  // modelled PSF leave <= 1.5 % of it; clipped regions of real panoramas whose surroundings are
  // scene content (sky, walls, no glare) leave 47-100 %, and fitting them anyway gave irradiance
  // errors 10-20x those of the unexpanded panorama. Such regions keep their observed values.
  double backgroundOnly = 0.0;
  {
    cv::Vec3d plane;
    if (!cv::solve(this->BackgroundNormal, this->BackgroundRhs, plane, cv::DECOMP_CHOLESKY))
    {
      cv::solve(this->BackgroundNormal, this->BackgroundRhs, plane, cv::DECOMP_SVD);
    }
    backgroundOnly = this->SumLuminanceSq - 2.0 * plane.dot(this->BackgroundRhs) +
      plane.dot(this->BackgroundNormal * plane);
  }
  auto explained = [backgroundOnly](double residual)
  { return backgroundOnly > 0.0 ? 1.0 - residual / backgroundOnly : 0.0; };

  // delta is scanned on a regular grid from -1 (the source is larger than the clipped region)
  // to the region's inner radius, every fourth point first: a region that even the best of
  // those leaves far from explained is declined without the rest of the scan (most clipped
  // regions of real panoramas; it saves ~75 % of their cost). When the halo itself clips far
  // out, fits over a range of delta are equally good (measured: residuals within 5 % while L
  // doubles), so the estimate is the centre of that valley -- the contiguous grid points within
  // ValleyTolerance of the smallest residual -- rather than its noisy minimum.
  constexpr double ValleyTolerance = 0.05;
  constexpr double EarlyDeclineMargin = 0.25;
  double background[3];
  float radiance = 0.0f;
  double residual = 0.0;
  const double lo = -1.0;
  const double hi = std::max(lo + 0.5, static_cast<double>(maxDepth) - 0.25);
  const int steps = std::clamp(static_cast<int>(std::ceil((hi - lo) / 0.25)), 2, 16);
  this->ScanResidual.assign(steps + 1, std::numeric_limits<double>::infinity());
  int best = 0;
  for (int pass = 0; pass < 2; ++pass)
  {
    for (int i = 0; i <= steps; ++i)
    {
      const bool coarse = i % 4 == 0 || i == steps;
      if (coarse != (pass == 0))
      {
        continue;
      }
      const double delta = lo + (hi - lo) * i / steps;
      this->evaluateSupport(static_cast<float>(delta), radiance, background, residual);
      this->ScanResidual[i] = residual;
      if (residual < this->ScanResidual[best])
      {
        best = i;
      }
    }
    if (!std::isfinite(this->ScanResidual[best]) ||
      explained(this->ScanResidual[best]) < p.MinExplainedFraction - EarlyDeclineMargin)
    {
      return false;
    }
  }
  if (!(explained(this->ScanResidual[best]) >= p.MinExplainedFraction))
  {
    return false;
  }
  const double limit = this->ScanResidual[best] * (1.0 + ValleyTolerance);
  int first = best;
  int last = best;
  while (first > 0 && this->ScanResidual[first - 1] <= limit)
  {
    --first;
  }
  while (last < steps && this->ScanResidual[last + 1] <= limit)
  {
    ++last;
  }
  const double bestDelta = lo + (hi - lo) * 0.5 * (first + last) / steps;
  this->evaluateSupport(static_cast<float>(bestDelta), radiance, background, residual);
  if (!std::isfinite(residual) || !(radiance > 0.0f))
  {
    return false;
  }

  // Colour: per-channel fits of the same model (the unclipped fringe carries the source's
  // chromaticity even when its core is clipped to white); the region's own mean colour when the
  // fringe is too faint to tell.
  cv::Matx44d normal = cv::Matx44d::zeros();
  cv::Vec4d rhs[3] = { cv::Vec4d::all(0.0), cv::Vec4d::all(0.0), cv::Vec4d::all(0.0) };
  glm::dvec3 coreColour(0.0);
  for (const Sample& s : this->Samples)
  {
    const cv::Vec3f v = linear.at<cv::Vec3f>(s.Pixel / w, s.Pixel % w);
    if (s.Kind == 1 || s.Kind == 4)
    {
      coreColour += glm::dvec3(v[0], v[1], v[2]);
    }
    if (s.Kind != 0)
    {
      continue;
    }
    const double row[4] = { 1.0, s.TangentX, s.TangentY, s.Model };
    for (int i = 0; i < 4; ++i)
    {
      for (int j = 0; j < 4; ++j)
      {
        normal(i, j) += row[i] * row[j];
      }
      for (int ch = 0; ch < 3; ++ch)
      {
        rhs[ch][i] += row[i] * v[ch];
      }
    }
  }
  glm::dvec3 fringe(0.0);
  for (int ch = 0; ch < 3; ++ch)
  {
    cv::Vec4d beta;
    if (!cv::solve(normal, rhs[ch], beta, cv::DECOMP_CHOLESKY))
    {
      cv::solve(normal, rhs[ch], beta, cv::DECOMP_SVD);
    }
    fringe[ch] = beta[3];
  }
  const double fringeLum = 0.2126 * fringe.x + 0.7152 * fringe.y + 0.0722 * fringe.z;
  glm::dvec3 colour(1.0);
  if (fringe.x > 0.0 && fringe.y > 0.0 && fringe.z > 0.0 && fringeLum > 0.25 * radiance)
  {
    colour = fringe / fringeLum;
  }
  else
  {
    const double coreLum = 0.2126 * coreColour.x + 0.7152 * coreColour.y + 0.0722 * coreColour.z;
    if (coreLum > 0.0)
    {
      colour = glm::max(coreColour / coreLum, glm::dvec3(0.0));
    }
  }

  // Per-channel background planes with the source fixed at L x colour, then Q on the region:
  // the model where it exceeds the observation (always, where the sensor clipped).
  double planes[3][3];
  {
    cv::Matx33d a3 = cv::Matx33d::zeros();
    cv::Vec3d r3[3] = { cv::Vec3d::all(0.0), cv::Vec3d::all(0.0), cv::Vec3d::all(0.0) };
    for (const Sample& s : this->Samples)
    {
      if (s.Kind != 0)
      {
        continue;
      }
      const cv::Vec3f v = linear.at<cv::Vec3f>(s.Pixel / w, s.Pixel % w);
      const double row[3] = { 1.0, s.TangentX, s.TangentY };
      for (int i = 0; i < 3; ++i)
      {
        for (int j = 0; j < 3; ++j)
        {
          a3(i, j) += row[i] * row[j];
        }
        for (int ch = 0; ch < 3; ++ch)
        {
          r3[ch][i] += row[i] * (v[ch] - radiance * colour[ch] * s.Model);
        }
      }
    }
    for (int ch = 0; ch < 3; ++ch)
    {
      cv::Vec3d plane;
      if (!cv::solve(a3, r3[ch], plane, cv::DECOMP_CHOLESKY))
      {
        cv::solve(a3, r3[ch], plane, cv::DECOMP_SVD);
      }
      for (int i = 0; i < 3; ++i)
      {
        planes[ch][i] = plane[i];
      }
    }
  }
  glm::dvec3 excessDirection(0.0);
  for (const Sample& s : this->Samples)
  {
    if (s.Kind != 1 && s.Kind != 4)
    {
      continue;
    }
    const int x = s.Pixel % w;
    const int y = s.Pixel / w;
    cv::Vec3f& out = q.at<cv::Vec3f>(y, x);
    double excess = 0.0;
    for (int ch = 0; ch < 3; ++ch)
    {
      const double bg = planes[ch][0] + planes[ch][1] * s.TangentX + planes[ch][2] * s.TangentY;
      const double model = bg + radiance * colour[ch] * s.Model;
      out[ch] = static_cast<float>(std::max(static_cast<double>(out[ch]), model));
      excess += (ch == 0 ? 0.2126 : (ch == 1 ? 0.7152 : 0.0722)) * (out[ch] - std::max(bg, 0.0));
    }
    excessDirection += std::max(excess, 0.0) * this->RowSolidAngle[y] * direction(x, y);
  }

  // Solid angle of the fitted support: patch pixel area x sin(rho) / rho (the area element of
  // the azimuthal-equidistant projection).
  double sourceSolidAngle = 0.0;
  for (int i = 0; i < k; ++i)
  {
    const float* s = this->Support.ptr<float>(i);
    for (int j = 0; j < k; ++j)
    {
      if (s[j] > 0.0f)
      {
        const double rho = std::hypot(j - centre, i - centre) * patchPitch;
        sourceSolidAngle +=
          s[j] * patchPitch * patchPitch * (rho > 0.0 ? std::sin(rho) / rho : 1.0);
      }
    }
  }

  light.Colour = glm::vec3(colour);
  light.SourceRadiance = radiance;
  light.SourceSolidAngle = static_cast<float>(sourceSolidAngle);
  light.Power = static_cast<float>(radiance * sourceSolidAngle);
  light.Direction =
    glm::vec3(glm::length(excessDirection) > 0.0 ? glm::normalize(excessDirection) : c0);
  light.Estimated = true;
  return true;
}

void LightSourceEstimator::estimate(const cv::Mat& linear, const cv::Mat& saturationMask,
  cv::Mat& radiance, std::vector<DetectedLight>& lights)
{
  this->validate(linear, saturationMask);
  this->prepareGeometry(linear.cols, linear.rows);
  this->computeBrightness(linear);
  const Parameters& p = this->Params;
  const float nearClip = p.NearClipFraction * p.ClipLevel;
  const float statistical =
    p.ThresholdMads > 0.0f ? this->statisticalThreshold(p.ThresholdMads) : 0.0f;
  this->Threshold = std::max(nearClip, statistical);
  this->Candidates.create(linear.size(), CV_8U);
  for (int y = 0; y < linear.rows; ++y)
  {
    const float* bright = this->Brightness.ptr<float>(y);
    const uchar* m = saturationMask.empty() ? nullptr : saturationMask.ptr<uchar>(y);
    uchar* out = this->Candidates.ptr<uchar>(y);
    for (int x = 0; x < linear.cols; ++x)
    {
      const bool clipped = bright[x] >= nearClip || (m && m[x] != 0);
      out[x] = clipped && bright[x] >= statistical ? 255 : 0;
    }
  }
  this->findRegions(this->Candidates, saturationMask, p.MinPeakFraction * p.ClipLevel);

  if (p.Operator == ExpansionOperator::Landis)
  {
    expandLandis(
      linear, radiance, p.ClipLevel, p.LandisThreshold, p.LandisExponent, p.LandisMaxRadiance);
  }
  else
  {
    linear.copyTo(radiance);
  }

  const int count = static_cast<int>(this->Regions.size());
  std::vector<DetectedLight> fitted(count);
  std::vector<char> isFitted(count, 0);
  if (p.Operator == ExpansionOperator::LightSourceModel)
  {
    std::vector<int> order(count);
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
      [this](int a, int b)
      { return this->Regions[a].Pixels.size() > this->Regions[b].Pixels.size(); });
    for (int i = 0; i < std::min(count, p.MaxFittedLights); ++i)
    {
      const int r = order[i];
      if (this->Regions[r].Clipped)
      {
        isFitted[r] = this->fitLight(linear, saturationMask, r, radiance, fitted[r]) ? 1 : 0;
      }
    }
  }
  lights.resize(count);
  for (int r = 0; r < count; ++r)
  {
    this->describe(radiance, this->Regions[r], lights[r]);
    if (isFitted[r])
    {
      lights[r].Colour = fitted[r].Colour;
      lights[r].SourceRadiance = fitted[r].SourceRadiance;
      lights[r].SourceSolidAngle = fitted[r].SourceSolidAngle;
      lights[r].Power = fitted[r].Power;
      lights[r].Direction = fitted[r].Direction;
      lights[r].Estimated = true;
    }
  }
  // Most powerful first; labels follow the new order.
  std::vector<int> order(count);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
    [&lights](int a, int b) { return lights[a].Power > lights[b].Power; });
  std::vector<DetectedLight> sorted(count);
  for (int i = 0; i < count; ++i)
  {
    sorted[i] = lights[order[i]];
    for (const int pixel : this->Regions[order[i]].Pixels)
    {
      this->Labels.at<int>(pixel / this->Width, pixel % this->Width) = i + 1;
    }
  }
  lights.swap(sorted);
}

void LightSourceEstimator::detect(const cv::Mat& radiance, std::vector<DetectedLight>& lights)
{
  this->validate(radiance, cv::Mat());
  this->prepareGeometry(radiance.cols, radiance.rows);
  this->computeBrightness(radiance);
  this->Threshold = this->statisticalThreshold(this->Params.HdrThresholdMads);
  cv::compare(this->Brightness, this->Threshold, this->Candidates, cv::CMP_GT);
  this->findRegions(this->Candidates, cv::Mat(), 0.0f);
  const int count = static_cast<int>(this->Regions.size());
  lights.resize(count);
  for (int r = 0; r < count; ++r)
  {
    this->describe(radiance, this->Regions[r], lights[r]);
    lights[r].Clipped = false;
  }
  std::vector<int> order(count);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
    [&lights](int a, int b) { return lights[a].Power > lights[b].Power; });
  std::vector<DetectedLight> sorted(count);
  for (int i = 0; i < count; ++i)
  {
    sorted[i] = lights[order[i]];
    for (const int pixel : this->Regions[order[i]].Pixels)
    {
      this->Labels.at<int>(pixel / this->Width, pixel % this->Width) = i + 1;
    }
  }
  lights.swap(sorted);
}
}
}
