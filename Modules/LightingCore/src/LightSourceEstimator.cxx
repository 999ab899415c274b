// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/LightSourceEstimator.h"

#include "SimdClones.h"

#include "hv/Equirectangular.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
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

// atan(x) for x >= 0 to float precision (Cephes' atanf: reduction to x <= tan(pi/8), then an odd
// polynomial; relative error below 2e-7), free of branches so that loops over a panorama row
// vectorise. std::atan2 costs ~10 ns a call and keeps the loop scalar.
inline float atanNonNegative(float x)
{
  const bool large = x > 2.414213562373095f;   // tan(3 pi / 8)
  const bool medium = x > 0.4142135623730950f; // tan(pi / 8)
  const float reduced = large ? -1.0f / std::max(x, 1.0f) : (medium ? (x - 1.0f) / (x + 1.0f) : x);
  const float offset = large ? 1.5707963267948966f : (medium ? 0.7853981633974483f : 0.0f);
  const float z = reduced * reduced;
  return offset +
    ((((8.05374449538e-2f * z - 1.38776856032e-1f) * z + 1.99777106478e-1f) * z -
       3.33329491539e-1f) *
        z * reduced +
      reduced);
}

// One row of the brightest channel of the non-negative part of RGB; false when a pixel is NaN
// or infinite (R + G + B not finite, as std::isfinite would say). Float bits with an all-ones
// exponent are exactly the non-finite values; the test is an integer OR, so that the loop
// vectorises (the per-pixel test and throw kept it scalar, 0.25 ms a frame). The luminance is
// computed only where the fits need it (SampleSet::append()).
HV_SIMD_CLONES
bool brightnessRow(int count, const float* __restrict rgb, float* __restrict bright)
{
  std::uint32_t nonFinite = 0;
  for (int x = 0; x < count; ++x)
  {
    const float sum = rgb[3 * x] + rgb[3 * x + 1] + rgb[3 * x + 2];
    std::uint32_t bits;
    std::memcpy(&bits, &sum, sizeof(bits));
    nonFinite |= (bits & 0x7f800000u) + 0x00800000u; // carries into bit 31 for 0xff exponents
    // Negative values (float noise of some HDR encoders) count as 0.
    bright[x] = std::max(std::max(rgb[3 * x], 0.0f),
      std::max(std::max(rgb[3 * x + 1], 0.0f), std::max(rgb[3 * x + 2], 0.0f)));
  }
  return (nonFinite & 0x80000000u) == 0;
}

// One row of light candidates (255 where the brightest channel reaches the near-clip level or
// the sensor clipped, and the statistical threshold); returns whether the row has any.
HV_SIMD_CLONES
uchar candidateRow(int count, const float* __restrict bright, const uchar* __restrict clipped,
  float nearClip, float statistical, uchar* __restrict out)
{
  uchar any = 0;
  if (clipped)
  {
    for (int x = 0; x < count; ++x)
    {
      // Bitwise, not short-circuit, operators: no branch in the loop.
      const bool candidate =
        ((bright[x] >= nearClip) | (clipped[x] != 0)) & (bright[x] >= statistical);
      out[x] = candidate ? 255 : 0;
      any |= out[x];
    }
  }
  else
  {
    for (int x = 0; x < count; ++x)
    {
      out[x] = bright[x] >= nearClip && bright[x] >= statistical ? 255 : 0;
      any |= out[x];
    }
  }
  return any != 0 ? 1 : 0;
}

// Per pixel of a run of one panorama row (direction from the row's sin/cos theta and the
// columns' sin/cos phi): cos of the angle rho to the light's centre c and the
// azimuthal-equidistant tangent coordinates rho (t.e1, t.e2) / |t|. Float arithmetic: the
// tangent coordinates are stored as floats, and their error here (~1e-7 rad, 1e-5 of a pixel)
// is of the same order. Restrict-qualified arrays and no branches, so that the loop vectorises.
HV_SIMD_CLONES
void tangentCoordinates(int count, const float* __restrict sinPhi, const float* __restrict cosPhi,
  float sinTheta, float cosTheta, const glm::vec3& c, const glm::vec3& e1, const glm::vec3& e2,
  float* __restrict cosRho, float* __restrict tangentX, float* __restrict tangentY)
{
  const float yC = cosTheta * c.y, yE1 = cosTheta * e1.y, yE2 = cosTheta * e2.y;
  for (int i = 0; i < count; ++i)
  {
    const float dx = sinTheta * sinPhi[i];
    const float dz = -sinTheta * cosPhi[i];
    const float cosine = dx * c.x + yC + dz * c.z;
    const float t1 = dx * e1.x + yE1 + dz * e1.z;
    const float t2 = dx * e2.x + yE2 + dz * e2.z;
    // rho = atan2(|t|, cos rho); cos rho > 0 within the window (at most 85 degrees), other
    // pixels are discarded by the caller.
    const float sine = std::sqrt(t1 * t1 + t2 * t2);
    const float rho = atanNonNegative(sine / std::max(cosine, 1e-6f));
    const float scale = sine > 1e-12f ? rho / sine : 1.0f;
    cosRho[i] = cosine;
    tangentX[i] = t1 * scale;
    tangentY[i] = t2 * scale;
  }
}

// Bilinear lookups (index, fractions) for many tangent positions at once, into a size x size
// patch that is `factor` times coarser than the fine patch (inversePitch: fine patch pixels per
// radian, centre: the fine patch's centre): coarse pixel i averages fine pixels [i f, (i + 1) f),
// so its centre is at i f + (f - 1) / 2. Index -1: outside the patch.
HV_SIMD_CLONES
void bilinearLookups(int count, const float* __restrict tangentX, const float* __restrict tangentY,
  float inversePitch, float centre, int size, int factor, int* __restrict index,
  float* __restrict fx, float* __restrict fy)
{
  const float inverseFactor = 1.0f / static_cast<float>(factor);
  const float offset = 0.5f * static_cast<float>(factor - 1);
  const float last = static_cast<float>(size - 1);
  for (int i = 0; i < count; ++i)
  {
    const float x = (tangentX[i] * inversePitch + centre - offset) * inverseFactor;
    const float y = (tangentY[i] * inversePitch + centre - offset) * inverseFactor;
    const bool inside = x >= 0.0f && y >= 0.0f && x <= last && y <= last;
    const int x0 = std::min(static_cast<int>(x), size - 2);
    const int y0 = std::min(static_cast<int>(y), size - 2);
    index[i] = inside ? y0 * size + x0 : -1;
    fx[i] = x - static_cast<float>(x0);
    fy[i] = y - static_cast<float>(y0);
  }
}

// The value of a bilinear lookup into a patch (rows of `cols` floats): 0 outside (index < 0),
// with a select instead of a branch so that loops over samples vectorise (AVX2 gathers).
inline float patchValue(const float* __restrict data, int cols, int index, float fx, float fy)
{
  const int i = index < 0 ? 0 : index;
  const float value = (1.0f - fy) * ((1.0f - fx) * data[i] + fx * data[i + 1]) +
    fy * ((1.0f - fx) * data[i + cols] + fx * data[i + cols + 1]);
  return index < 0 ? 0.0f : value;
}

// The model B = coreWeight x core-blurred support + h x halo-blurred support at many samples
// (haloImage null: core alone), from their lookups into the patches; true when any B exceeds
// 1e-6 (the support is not empty there).
HV_SIMD_CLONES
bool blurredSupportAt(int count, const int* __restrict fineIndex, const float* __restrict fineFx,
  const float* __restrict fineFy, const int* __restrict coarseIndex,
  const float* __restrict coarseFx, const float* __restrict coarseFy, const float* __restrict core,
  int coreCols, const float* __restrict haloImage, int haloCols, float coreWeight, float halo,
  float* __restrict model)
{
  int any = 0;
  if (haloImage)
  {
    for (int i = 0; i < count; ++i)
    {
      float b = coreWeight * patchValue(core, coreCols, fineIndex[i], fineFx[i], fineFy[i]);
      b += halo * patchValue(haloImage, haloCols, coarseIndex[i], coarseFx[i], coarseFy[i]);
      model[i] = b;
      any |= b > 1e-6f;
    }
  }
  else
  {
    for (int i = 0; i < count; ++i)
    {
      const float b = coreWeight * patchValue(core, coreCols, fineIndex[i], fineFx[i], fineFy[i]);
      model[i] = b;
      any |= b > 1e-6f;
    }
  }
  return any != 0;
}

// The set each pixel of a row run joins (see fitLight()): 0 none, 1 fitted (unclipped, in the
// window, outside the guard band), 2 constraint (in the region, deeper than the guard band),
// 3 interior (in the region's guard band). clipped may be null.
HV_SIMD_CLONES
void classifyRow(int count, const int* __restrict labels, const float* __restrict bright,
  const uchar* __restrict clipped, const float* __restrict cosRho, const float* __restrict depth,
  int regionLabel, float nearClip, float cosWindow, float guard, uchar* __restrict kind)
{
  for (int i = 0; i < count; ++i)
  {
    const bool elsewhere = (labels[i] != 0) | (bright[i] >= nearClip) | (depth[i] > -guard);
    const uchar outside = elsewhere ? 0 : 1;
    const uchar region = depth[i] < guard ? 3 : 2;
    const uchar inWindow = cosRho[i] < cosWindow ? 0 : 1;
    kind[i] = inWindow * (labels[i] == regionLabel ? region : outside);
  }
  if (clipped)
  {
    for (int i = 0; i < count; ++i)
    {
      kind[i] = clipped[i] != 0 && kind[i] == 1 ? 0 : kind[i];
    }
  }
}

// The signed distance to the region (bilinear on the fine patch) at many lookups.
HV_SIMD_CLONES
void signedDistanceAt(int count, const int* __restrict index, const float* __restrict fx,
  const float* __restrict fy, const float* __restrict signedDistance, int cols,
  float* __restrict depth)
{
  for (int i = 0; i < count; ++i)
  {
    depth[i] = patchValue(signedDistance, cols, index[i], fx[i], fy[i]);
  }
}

// Sums over the fitted samples of B, X B, Y B, B^2 and B Y_obs (in that order), in double.
// Four interleaved partial sums each: one chain of dependent additions was the loop's limit.
HV_SIMD_CLONES
void supportMoments(int count, const float* __restrict model, const float* __restrict tangentX,
  const float* __restrict tangentY, const float* __restrict luminance, double sums[5])
{
  double partial[5][4] = {};
  int i = 0;
  for (; i + 4 <= count; i += 4)
  {
    for (int lane = 0; lane < 4; ++lane)
    {
      const double b = model[i + lane];
      partial[0][lane] += b;
      partial[1][lane] += tangentX[i + lane] * b;
      partial[2][lane] += tangentY[i + lane] * b;
      partial[3][lane] += b * b;
      partial[4][lane] += b * luminance[i + lane];
    }
  }
  for (; i < count; ++i)
  {
    const double b = model[i];
    partial[0][0] += b;
    partial[1][0] += tangentX[i] * b;
    partial[2][0] += tangentY[i] * b;
    partial[3][0] += b * b;
    partial[4][0] += b * luminance[i];
  }
  for (int m = 0; m < 5; ++m)
  {
    sums[m] = (partial[m][0] + partial[m][1]) + (partial[m][2] + partial[m][3]);
  }
}

// The background plane's normal equations over the fitted samples: n, sum X, sum Y, sum X^2,
// sum X Y, sum Y^2, sum Y_obs, sum X Y_obs, sum Y Y_obs, sum Y_obs^2, in double, with four
// interleaved partial sums each (as supportMoments()).
HV_SIMD_CLONES
void planeMoments(int count, const float* __restrict tangentX, const float* __restrict tangentY,
  const float* __restrict luminance, double sums[10])
{
  double partial[10][4] = {};
  int i = 0;
  for (; i + 4 <= count; i += 4)
  {
    for (int lane = 0; lane < 4; ++lane)
    {
      const double x = tangentX[i + lane];
      const double y = tangentY[i + lane];
      const double l = luminance[i + lane];
      partial[0][lane] += 1.0;
      partial[1][lane] += x;
      partial[2][lane] += y;
      partial[3][lane] += x * x;
      partial[4][lane] += x * y;
      partial[5][lane] += y * y;
      partial[6][lane] += l;
      partial[7][lane] += x * l;
      partial[8][lane] += y * l;
      partial[9][lane] += l * l;
    }
  }
  for (; i < count; ++i)
  {
    const double x = tangentX[i];
    const double y = tangentY[i];
    const double l = luminance[i];
    partial[0][0] += 1.0;
    partial[1][0] += x;
    partial[2][0] += y;
    partial[3][0] += x * x;
    partial[4][0] += x * y;
    partial[5][0] += y * y;
    partial[6][0] += l;
    partial[7][0] += x * l;
    partial[8][0] += y * l;
    partial[9][0] += l * l;
  }
  for (int m = 0; m < 10; ++m)
  {
    sums[m] = (partial[m][0] + partial[m][1]) + (partial[m][2] + partial[m][3]);
  }
}

// S = clamp(SD + shift, 0, 1) over a patch (cv::add and two cv::threshold calls, in one pass).
HV_SIMD_CLONES
void clampedShift(
  int count, const float* __restrict signedDistance, float shift, float* __restrict support)
{
  for (int i = 0; i < count; ++i)
  {
    support[i] = std::min(std::max(signedDistance[i] + shift, 0.0f), 1.0f);
  }
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
  if (expanded.data != linear.data) // in place: expanded already holds the input
  {
    linear.copyTo(expanded);
  }
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

void LightSourceEstimator::tangentRow(int y, int first, int count)
{
  TangentRowBuffers& row = this->Row;
  row.resize(count);
  const TangentFrame& frame = this->Frame;
  tangentCoordinates(count, this->SinPhi.data() + first, this->CosPhi.data() + first,
    this->SinTheta[y], this->CosTheta[y], frame.Centre, frame.Axis1, frame.Axis2, row.CosRho.data(),
    row.TangentX.data(), row.TangentY.data());
  const int k = frame.PatchSize;
  const int f = frame.HaloFactor;
  bilinearLookups(count, row.TangentX.data(), row.TangentY.data(), frame.InversePitch,
    frame.PatchCentre, k, 1, row.FineIndex.data(), row.FineFx.data(), row.FineFy.data());
  bilinearLookups(count, row.TangentX.data(), row.TangentY.data(), frame.InversePitch,
    frame.PatchCentre, k / f, f, row.CoarseIndex.data(), row.CoarseFx.data(), row.CoarseFy.data());
  signedDistanceAt(count, row.FineIndex.data(), row.FineFx.data(), row.FineFy.data(),
    this->SignedDistance.ptr<float>(), k, row.Depth.data());
}

void LightSourceEstimator::TangentRowBuffers::resize(int count)
{
  if (static_cast<int>(this->CosRho.size()) >= count)
  {
    return;
  }
  for (std::vector<float>* v : { &this->CosRho, &this->TangentX, &this->TangentY, &this->Depth,
         &this->FineFx, &this->FineFy, &this->CoarseFx, &this->CoarseFy })
  {
    v->resize(count);
  }
  this->FineIndex.resize(count);
  this->CoarseIndex.resize(count);
  this->Kind.resize(count);
  for (std::vector<int>& members : this->Members)
  {
    members.resize(count + 1);
  }
}

void LightSourceEstimator::SampleSet::append(
  const TangentRowBuffers& row, const int* members, int count, const float* rgb, int firstPixel)
{
  if (count == 0)
  {
    return;
  }
  const int start = this->Count;
  this->Count += count;
  if (static_cast<int>(this->Pixel.size()) < this->Count)
  {
    // Grown geometrically and never shrunk: the arrays are written, not value-initialised, in
    // the steady state.
    const size_t capacity = std::max<size_t>(2 * this->Count, 1024);
    for (std::vector<float>* v : { &this->TangentX, &this->TangentY, &this->Luminance, &this->Model,
           &this->FineFx, &this->FineFy, &this->CoarseFx, &this->CoarseFy })
    {
      v->resize(capacity);
    }
    this->FineIndex.resize(capacity);
    this->CoarseIndex.resize(capacity);
    this->Pixel.resize(capacity);
  }
  auto gather = [members, count, start](auto& out, const auto* in)
  {
    auto* destination = out.data() + start;
    for (int j = 0; j < count; ++j)
    {
      destination[j] = in[members[j]];
    }
  };
  gather(this->TangentX, row.TangentX.data());
  gather(this->TangentY, row.TangentY.data());
  // Rec. 709 luminance of the non-negative part of RGB (negative values: float noise of some HDR
  // encoders).
  float* luminance = this->Luminance.data() + start;
  for (int j = 0; j < count; ++j)
  {
    const float* v = rgb + 3 * members[j];
    luminance[j] = rec709(std::max(v[0], 0.0f), std::max(v[1], 0.0f), std::max(v[2], 0.0f));
  }
  gather(this->FineIndex, row.FineIndex.data());
  gather(this->FineFx, row.FineFx.data());
  gather(this->FineFy, row.FineFy.data());
  gather(this->CoarseIndex, row.CoarseIndex.data());
  gather(this->CoarseFx, row.CoarseFx.data());
  gather(this->CoarseFy, row.CoarseFy.data());
  int* pixel = this->Pixel.data() + start;
  for (int j = 0; j < count; ++j)
  {
    pixel[j] = firstPixel + members[j];
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
  this->Brightness.create(linear.size(), CV_32F);
  for (int y = 0; y < linear.rows; ++y)
  {
    if (!brightnessRow(linear.cols, linear.ptr<float>(y), this->Brightness.ptr<float>(y)))
    {
      throw std::invalid_argument("LightSourceEstimator: the panorama holds NaN or infinite "
                                  "values; replace them (e.g. cv::patchNaNs) before "
                                  "estimating.");
    }
  }
}

void LightSourceEstimator::markRowsWithCandidates()
{
  this->RowHasCandidates.resize(this->Candidates.rows);
  for (int y = 0; y < this->Candidates.rows; ++y)
  {
    this->RowHasCandidates[y] = cv::countNonZero(this->Candidates.row(y)) > 0 ? 1 : 0;
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
  const int w = this->Width;
  const int h = this->Height;
  // Only the rows between the first and the last with a candidate are labelled and scanned
  // (lights cover a few percent of the sphere); labels there are those of the whole image, as
  // connectedComponents numbers components in raster order.
  const std::vector<uchar>& rowHas = this->RowHasCandidates;
  int firstRow = 0;
  while (firstRow < h && !rowHas[firstRow])
  {
    ++firstRow;
  }
  int lastRow = h - 1;
  while (lastRow >= firstRow && !rowHas[lastRow])
  {
    --lastRow;
  }
  // Labels hold the previous call's regions in rows [LabelledRows[0], LabelledRows[1]) at most:
  // only those rows are cleared (a new or resized image is cleared whole).
  if (this->Labels.rows != h || this->Labels.cols != w || this->Labels.type() != CV_32S)
  {
    this->Labels.create(h, w, CV_32S);
    this->LabelledRows[0] = 0;
    this->LabelledRows[1] = h;
  }
  if (this->LabelledRows[1] > this->LabelledRows[0])
  {
    this->Labels.rowRange(this->LabelledRows[0], this->LabelledRows[1]).setTo(0);
  }
  this->LabelledRows[0] = std::min(firstRow, h);
  this->LabelledRows[1] = std::max(lastRow + 1, this->LabelledRows[0]);
  if (firstRow > lastRow)
  {
    this->Regions.clear();
    return;
  }
  // Without statistics: connectedComponentsWithStats took 0.8 ms at 512 x 256 here, the
  // labelling alone 0.08 ms; the areas are counted below.
  // The labels go to the top rows of a whole-panorama buffer: a label image of the band's own
  // size would be reallocated (and its pages faulted in) whenever the band changes.
  this->ComponentBuffer.create(h, w, CV_32S);
  this->ComponentLabels = this->ComponentBuffer.rowRange(0, lastRow + 1 - firstRow);
  const int n = cv::connectedComponents(
    candidates.rowRange(firstRow, lastRow + 1), this->ComponentLabels, 8, CV_32S);
  auto componentRow = [this, firstRow](int y)
  { return this->ComponentLabels.ptr<int>(y - firstRow); };
  this->Parent.resize(n);
  std::iota(this->Parent.begin(), this->Parent.end(), 0);
  // connectedComponents sees a flat image: the u = 0 / u = 1 seam and the poles (every pixel of
  // the first and last rows touches the pole) are joined here with a union-find over labels.
  for (int y = firstRow; y <= lastRow; ++y)
  {
    const int a = componentRow(y)[0];
    if (a == 0)
    {
      continue;
    }
    for (int yy = std::max(firstRow, y - 1); yy <= std::min(lastRow, y + 1); ++yy)
    {
      const int b = componentRow(yy)[w - 1];
      if (b != 0)
      {
        unite(this->Parent, a, b);
      }
    }
  }
  for (const int row : { 0, h - 1 })
  {
    if (row < firstRow || row > lastRow)
    {
      continue;
    }
    int first = 0;
    const int* labels = componentRow(row);
    for (int x = 0; x < w; ++x)
    {
      const int a = labels[x];
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
  for (int y = firstRow; y <= lastRow; ++y)
  {
    if (!rowHas[y])
    {
      continue;
    }
    const int* label = componentRow(y);
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
  for (int y = firstRow; y <= lastRow; ++y)
  {
    if (!rowHas[y])
    {
      continue;
    }
    const int* label = componentRow(y);
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
    int* labels = this->Labels.ptr<int>(); // continuous: index = y * w + x
    int kept = 0;
    for (int r = 0; r < regions; ++r)
    {
      Region& region = this->Regions[r];
      if (region.Peak < minPeak)
      {
        for (const int pixel : region.Pixels)
        {
          labels[pixel] = 0;
        }
        continue;
      }
      if (kept != r)
      {
        std::swap(this->Regions[kept], region);
        for (const int pixel : this->Regions[kept].Pixels)
        {
          labels[pixel] = kept + 1;
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
  std::vector<char>& columns = this->ColumnScratch;
  columns.assign(w, 0);
  for (const int p : region.Pixels)
  {
    const int y = p / w;
    const int x = p - y * w;
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
  const int k = this->SignedDistance.rows;
  this->Support.create(k, k, CV_32F);
  clampedShift(k * k, this->SignedDistance.ptr<float>(), static_cast<float>(0.5 - delta),
    this->Support.ptr<float>());
  cv::GaussianBlur(
    this->Support, this->CoreBlur, cv::Size(0, 0), coreSigma, coreSigma, cv::BORDER_CONSTANT);
  const float halo = p.HaloFraction;
  const cv::Mat* model = &this->CoreBlur;
  float coreWeight = 1.0f - halo;
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
      cv::resize(
        this->Support, this->HaloSupport, cv::Size(k / f, k / f), 0.0, 0.0, cv::INTER_AREA);
      cv::GaussianBlur(this->HaloSupport, this->HaloBlur, cv::Size(0, 0), coarseSigma, coarseSigma,
        cv::BORDER_CONSTANT);
    }
    else
    {
      // Same grid, same lookups: B = ((1 - h) core + h halo) at each sample, one lookup.
      cv::GaussianBlur(this->Support, this->HaloBlur, cv::Size(0, 0), coarseSigma, coarseSigma,
        cv::BORDER_CONSTANT);
      cv::addWeighted(this->CoreBlur, 1.0 - halo, this->HaloBlur, halo, 0.0, this->ModelPatch);
      model = &this->ModelPatch;
      coreWeight = 1.0f;
    }
  }
  const bool separateHalo = halo > 0.0f && model == &this->CoreBlur;

  // The blurred support B at every sample (kept for the colour fit and Q once delta is chosen).
  bool anyModel = false;
  for (SampleSet* set : { &this->Fitted, &this->Constraints, &this->Interior })
  {
    anyModel =
      blurredSupportAt(set->size(), set->FineIndex.data(), set->FineFx.data(), set->FineFy.data(),
        set->CoarseIndex.data(), set->CoarseFx.data(), set->CoarseFy.data(), model->ptr<float>(),
        model->cols, separateHalo ? this->HaloBlur.ptr<float>() : nullptr,
        separateHalo ? this->HaloBlur.cols : 0, coreWeight, halo, set->Model.data()) ||
      anyModel;
  }
  if (!anyModel)
  {
    residual = std::numeric_limits<double>::infinity();
    return 0.0f;
  }

  // Linear least squares for Y = b0 + b1 X + b2 Y' + L B over the fitted samples. The
  // background's part of the normal equations does not depend on delta (precomputed in
  // fitLight); only the sums involving B are accumulated here.
  double sums[5];
  supportMoments(this->Fitted.size(), this->Fitted.Model.data(), this->Fitted.TangentX.data(),
    this->Fitted.TangentY.data(), this->Fitted.Luminance.data(), sums);
  const double sumB = sums[0], sumXB = sums[1], sumYB = sums[2], sumBB = sums[3], sumBLum = sums[4];
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
  {
    const SampleSet& s = this->Constraints;
    for (int i = 0; i < s.size(); ++i)
    {
      if (s.Model[i] > 1e-4f)
      {
        const double bg = beta[0] + beta[1] * s.TangentX[i] + beta[2] * s.TangentY[i];
        lMin = std::max(lMin, (s.Luminance[i] - bg) / s.Model[i]);
      }
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

bool LightSourceEstimator::fitLight(const cv::Mat& linear, const cv::Mat& mask, int index,
  cv::Mat& q, bool& qWritten, DetectedLight& light)
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
    const int y = pixel / w;
    sum += static_cast<double>(this->RowSolidAngle[y]) * direction(pixel - y * w, y);
  }
  if (!(glm::length(sum) > 1e-12))
  {
    return false;
  }
  const glm::dvec3 c0 = glm::normalize(sum);
  // The largest angle from the centre is that of the smallest cosine (one acos per region).
  double smallestCos = 1.0;
  for (const int pixel : region.Pixels)
  {
    const int y = pixel / w;
    smallestCos = std::min(smallestCos, glm::dot(direction(pixel - y * w, y), c0));
  }
  double coreRadius = std::acos(std::max(smallestCos, -1.0));
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
  // Only patch pixels near a region pixel can fall in the region: a panorama pixel's points lie
  // within 0.71 pitch of its centre, at most 1.25 times that in the tangent plane within 64
  // degrees of the light (rho / sin rho; the raster radius is at most 60 degrees plus a pixel
  // and a patch pixel), so within 0.9 patch pixels (the patch is at least as coarse as the
  // panorama) of the centre's tangent position; the 5 x 5 patch pixels around it hold them all. The
  // exact test below (one sin, cos, atan2 and acos per patch pixel) then runs on these only:
  // elongated regions cover a small part of their enclosing disk.
  this->RasterCandidates.create(k, k, CV_8U);
  this->RasterCandidates.setTo(0);
  {
    const glm::vec3 c(c0), a1(e1), a2(e2);
    const float inversePitch = static_cast<float>(1.0 / patchPitch);
    const float middle = static_cast<float>(centre);
    for (const int pixel : region.Pixels)
    {
      const int y = pixel / w;
      const int x = pixel - y * w;
      const glm::vec3 d(this->SinTheta[y] * this->SinPhi[x], this->CosTheta[y],
        -this->SinTheta[y] * this->CosPhi[x]);
      const float t1 = glm::dot(d, a1);
      const float t2 = glm::dot(d, a2);
      const float sine = std::sqrt(t1 * t1 + t2 * t2);
      const float rho = atanNonNegative(sine / std::max(glm::dot(d, c), 1e-6f));
      const float scale = sine > 1e-12f ? rho / sine * inversePitch : inversePitch;
      const int px = static_cast<int>(std::floor(t1 * scale + middle));
      const int py = static_cast<int>(std::floor(t2 * scale + middle));
      for (int i = std::max(0, py - 2); i <= std::min(k - 1, py + 2); ++i)
      {
        uchar* row = this->RasterCandidates.ptr<uchar>(i);
        for (int j = std::max(0, px - 2); j <= std::min(k - 1, px + 2); ++j)
        {
          row[j] = 1;
        }
      }
    }
  }
  const double rasterRadius = coreRadius + patchPitch;
  const double rasterRows = rasterRadius / patchPitch;
  cv::Rect box(k, k, -1, -1); // bounding box of the rasterised region (corners inclusive)
  for (int i = std::max(0, static_cast<int>(std::floor(centre - rasterRows)));
       i <= std::min(k - 1, static_cast<int>(std::ceil(centre + rasterRows))); ++i)
  {
    uchar* row = this->CoreMask.ptr<uchar>(i);
    const uchar* candidate = this->RasterCandidates.ptr<uchar>(i);
    const double y = (i - centre) * patchPitch;
    for (int j = 0; j < k; ++j)
    {
      if (!candidate[j])
      {
        continue;
      }
      const double x = (j - centre) * patchPitch;
      const double rho = std::sqrt(x * x + y * y);
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
        box.x = std::min(box.x, j);
        box.y = std::min(box.y, i);
        box.width = std::max(box.width, j);   // the last column, for now
        box.height = std::max(box.height, i); // the last row, for now
      }
    }
  }
  if (box.width < 0)
  {
    return false;
  }
  // Signed distance to the region's boundary (patch pixels, > 0 inside). Samples in a guard
  // band around the boundary are treated apart (see below), and the support of
  // evaluateSupport() starts 1.5 pixels outside: far from the region only "further than the
  // guard band" matters. The distances are computed on the region's box widened by the band
  // and a margin (the exact values there: the nearest region pixel and the chamfer path to it
  // lie in the box), which saves most of their cost for small regions; further out SD is set to
  // a value beyond the band.
  const double coreSigmaPixels = coreSigma / patchPitch;
  const float guard = static_cast<float>(std::max(1.0, 2.0 * coreSigmaPixels) + 0.5);
  const int band = static_cast<int>(std::ceil(guard)) + 4;
  const cv::Rect roi = cv::Rect(cv::Point(box.x - band, box.y - band),
                         cv::Point(box.width + 1 + band, box.height + 1 + band)) &
    cv::Rect(0, 0, k, k);
  this->SignedDistance.create(k, k, CV_32F);
  this->SignedDistance.setTo(-static_cast<float>(band));
  const cv::Mat regionMask = this->CoreMask(roi);
  cv::distanceTransform(regionMask, this->InsideDistance, cv::DIST_L2, cv::DIST_MASK_5);
  cv::bitwise_not(regionMask, this->OutsideMask);
  cv::distanceTransform(this->OutsideMask, this->OutsideDistance, cv::DIST_L2, cv::DIST_MASK_5);
  float maxDepth = 0.0f;
  for (int i = 0; i < roi.height; ++i)
  {
    const float* in = this->InsideDistance.ptr<float>(i);
    const float* out = this->OutsideDistance.ptr<float>(i);
    float* sd = this->SignedDistance.ptr<float>(roi.y + i) + roi.x;
    for (int j = 0; j < roi.width; ++j)
    {
      sd[j] = in[j] > 0.0f ? in[j] - 0.5f : 0.5f - out[j];
      maxDepth = std::max(maxDepth, sd[j]);
    }
  }

  // Panorama pixels within the window, each with its tangent position, sorted as they come
  // into the fitted surroundings, the constraining interior and the rest of the region.
  this->Fitted.clear();
  this->Constraints.clear();
  this->Interior.clear();
  const float nearClip = p.NearClipFraction * p.ClipLevel;
  const double thetaC = std::acos(glm::clamp(c0.y, -1.0, 1.0));
  const double cosWindow = std::cos(window);
  const int y0 = std::max(0, static_cast<int>(std::floor((thetaC - window) / Pi * h)));
  const int y1 = std::min(h - 1, static_cast<int>(std::ceil((thetaC + window) / Pi * h)));
  const bool aroundPole = thetaC - window <= 0.0 || thetaC + window >= Pi;
  const double uC = hv::directionToEquirectangular(glm::vec3(c0)).x;
  this->Frame.Centre = glm::vec3(c0);
  this->Frame.Axis1 = glm::vec3(e1);
  this->Frame.Axis2 = glm::vec3(e2);
  this->Frame.InversePitch = static_cast<float>(1.0 / patchPitch);
  this->Frame.PatchCentre = static_cast<float>(centre);
  this->Frame.PatchSize = k;
  this->Frame.HaloFactor = f;
  // Samples within a guard band of the region's boundary (2 core sigmas + 1/2 pixel) do not
  // enter the fit: there the model is the far tail of the core PSF, which multiplies the
  // +-1/2-pixel raster error of the boundary into errors of a factor of several (measured: it
  // drove the fit to point-like sources with 3-4x the true power). The halo further out and the
  // region's interior carry the information. The band outside is dropped; the band inside is
  // part of the light but constrains nothing.
  const int regionLabel = index + 1;
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
    const int* labels = this->Labels.ptr<int>(y);
    const float* bright = this->Brightness.ptr<float>(y);
    const float* rgb = linear.ptr<float>(y);
    const uchar* m = mask.empty() ? nullptr : mask.ptr<uchar>(y);
    // The span may cross the u seam: at most two runs of contiguous columns.
    const int start = (xFirst % w + w) % w;
    const int runs[2][2] = { { start, std::min(w, start + xCount) },
      { 0, std::max(0, start + xCount - w) } };
    for (const auto& run : runs)
    {
      const int first = run[0];
      const int count = run[1] - run[0];
      if (count <= 0)
      {
        continue;
      }
      this->tangentRow(y, first, count);
      // Which set each pixel of the run joins: 0 none, 1 fitted, 2 constraint, 3 interior.
      // A pixel clipped but not of this light carries no information about it; the guard
      // band outside the region is dropped.
      uchar* kind = this->Row.Kind.data();
      classifyRow(count, labels + first, bright + first, m ? m + first : nullptr,
        this->Row.CosRho.data(), this->Row.Depth.data(), regionLabel, nearClip,
        static_cast<float>(cosWindow), guard, kind);
      int* byKind[3] = { this->Row.Members[0].data(), this->Row.Members[1].data(),
        this->Row.Members[2].data() };
      int members[3] = { 0, 0, 0 };
      for (int i = 0; i < count; ++i)
      {
        // Branch-free: every list is written, only the matching one advances.
        for (int set = 0; set < 3; ++set)
        {
          byKind[set][members[set]] = i;
          members[set] += kind[i] == set + 1 ? 1 : 0;
        }
      }
      SampleSet* sets[3] = { &this->Fitted, &this->Constraints, &this->Interior };
      for (int set = 0; set < 3; ++set)
      {
        sets[set]->append(this->Row, byKind[set], members[set], rgb + 3 * first, y * w + first);
      }
    }
  }
  if (this->Fitted.size() < 16)
  {
    return false;
  }
  {
    // n, sum X, sum Y, sum X^2, sum X Y, sum Y^2, sum Y_obs, sum X Y_obs, sum Y Y_obs, sum Y_obs^2
    double m[10];
    planeMoments(this->Fitted.size(), this->Fitted.TangentX.data(), this->Fitted.TangentY.data(),
      this->Fitted.Luminance.data(), m);
    this->BackgroundNormal = cv::Matx33d(m[0], m[1], m[2], m[1], m[3], m[4], m[2], m[4], m[5]);
    this->BackgroundRhs = cv::Vec3d(m[6], m[7], m[8]);
    this->SumLuminanceSq = m[9];
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
  for (const SampleSet* set : { &this->Constraints, &this->Interior })
  {
    for (int s = 0; s < set->size(); ++s)
    {
      const int pixel = set->Pixel[s];
      const cv::Vec3f v = linear.at<cv::Vec3f>(pixel / w, pixel % w);
      coreColour += glm::dvec3(v[0], v[1], v[2]);
    }
  }
  for (int s = 0; s < this->Fitted.size(); ++s)
  {
    const int pixel = this->Fitted.Pixel[s];
    const cv::Vec3f v = linear.at<cv::Vec3f>(pixel / w, pixel % w);
    const double row[4] = { 1.0, this->Fitted.TangentX[s], this->Fitted.TangentY[s],
      this->Fitted.Model[s] };
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
    for (int s = 0; s < this->Fitted.size(); ++s)
    {
      const int pixel = this->Fitted.Pixel[s];
      const cv::Vec3f v = linear.at<cv::Vec3f>(pixel / w, pixel % w);
      const double row[3] = { 1.0, this->Fitted.TangentX[s], this->Fitted.TangentY[s] };
      for (int i = 0; i < 3; ++i)
      {
        for (int j = 0; j < 3; ++j)
        {
          a3(i, j) += row[i] * row[j];
        }
        for (int ch = 0; ch < 3; ++ch)
        {
          r3[ch][i] += row[i] * (v[ch] - radiance * colour[ch] * this->Fitted.Model[s]);
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
  if (!qWritten)
  {
    linear.copyTo(q); // the first light whose radiance is restored
    qWritten = true;
  }
  for (const SampleSet* set : { &this->Constraints, &this->Interior })
  {
    for (int s = 0; s < set->size(); ++s)
    {
      const int x = set->Pixel[s] % w;
      const int y = set->Pixel[s] / w;
      cv::Vec3f& out = q.at<cv::Vec3f>(y, x);
      double excess = 0.0;
      for (int ch = 0; ch < 3; ++ch)
      {
        const double bg =
          planes[ch][0] + planes[ch][1] * set->TangentX[s] + planes[ch][2] * set->TangentY[s];
        const double model = bg + radiance * colour[ch] * set->Model[s];
        out[ch] = static_cast<float>(std::max(static_cast<double>(out[ch]), model));
        excess += (ch == 0 ? 0.2126 : (ch == 1 ? 0.7152 : 0.0722)) * (out[ch] - std::max(bg, 0.0));
      }
      excessDirection += std::max(excess, 0.0) * this->RowSolidAngle[y] * direction(x, y);
    }
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
  cv::Mat& radiance, std::vector<DetectedLight>& lights, bool* radianceIsInput)
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
  this->RowHasCandidates.resize(linear.rows);
  for (int y = 0; y < linear.rows; ++y)
  {
    this->RowHasCandidates[y] = candidateRow(linear.cols, this->Brightness.ptr<float>(y),
      saturationMask.empty() ? nullptr : saturationMask.ptr<uchar>(y), nearClip, statistical,
      this->Candidates.ptr<uchar>(y));
  }
  this->findRegions(this->Candidates, saturationMask, p.MinPeakFraction * p.ClipLevel);

  // Q starts as the input: copied now, already there in place (same data), or, when the caller
  // allows (radianceIsInput), copied only before the first restored light writes to it.
  bool written = true;
  if (p.Operator == ExpansionOperator::Landis)
  {
    expandLandis(
      linear, radiance, p.ClipLevel, p.LandisThreshold, p.LandisExponent, p.LandisMaxRadiance);
  }
  else if (radiance.data != linear.data)
  {
    written = radianceIsInput == nullptr;
    if (written)
    {
      linear.copyTo(radiance);
    }
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
        isFitted[r] =
          this->fitLight(linear, saturationMask, r, radiance, written, fitted[r]) ? 1 : 0;
      }
    }
  }
  if (radianceIsInput)
  {
    *radianceIsInput = !written;
  }
  lights.resize(count);
  for (int r = 0; r < count; ++r)
  {
    this->describe(written ? radiance : linear, this->Regions[r], lights[r]);
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
  int* labels = this->Labels.ptr<int>(); // continuous: index = y * w + x
  for (int i = 0; i < count; ++i)
  {
    sorted[i] = lights[order[i]];
    for (const int pixel : this->Regions[order[i]].Pixels)
    {
      labels[pixel] = i + 1;
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
  this->markRowsWithCandidates();
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
  int* labels = this->Labels.ptr<int>(); // continuous: index = y * w + x
  for (int i = 0; i < count; ++i)
  {
    sorted[i] = lights[order[i]];
    for (const int pixel : this->Regions[order[i]].Pixels)
    {
      labels[pixel] = i + 1;
    }
  }
  lights.swap(sorted);
}
}
}
