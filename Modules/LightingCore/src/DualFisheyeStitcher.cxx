// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/DualFisheyeStitcher.h"

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
constexpr double PiD = 3.14159265358979323846;
constexpr double DegreesToRadians = PiD / 180.0;
// Where a remap table points for "no sample": far enough outside any frame that the
// bilinear footprint only sees cv::BORDER_CONSTANT zeros, small enough for CV_16SC2.
constexpr float NoSample = -64.0f;
constexpr std::uint8_t NoLens = 255;

// hv::equirectangularToDirection / directionToEquirectangular in double precision: the remap
// tables of frames thousands of pixels wide need positions better than float's.
glm::dvec3 panoramaDirection(double u, double v)
{
  const double phi = (u - 0.5) * 2.0 * PiD;
  const double theta = v * PiD;
  const double sinTheta = std::sin(theta);
  return glm::dvec3(sinTheta * std::sin(phi), std::cos(theta), -sinTheta * std::cos(phi));
}

glm::dvec2 panoramaCoordinates(const glm::dvec3& d)
{
  double u = 0.5 + std::atan2(d.x, -d.z) / (2.0 * PiD);
  u = u >= 1.0 ? u - 1.0 : u;
  const double v = std::acos(std::clamp(d.y, -1.0, 1.0)) / PiD;
  return glm::dvec2(u, v);
}

// Angle subtended by `pixels` frame pixels radially at the edge of the field of view.
double edgeAngleOfPixels(const FisheyeLensD& lens, double pixels)
{
  const double delta = 1e-4;
  const double slope =
    (fisheyeRadius(lens, lens.MaxTheta) - fisheyeRadius(lens, lens.MaxTheta - delta)) / delta;
  return pixels / std::max(slope, 1e-9);
}

double smoothstep(double t)
{
  t = std::clamp(t, 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

std::string sizeText(const cv::Size& size)
{
  return std::to_string(size.width) + "x" + std::to_string(size.height);
}

void validateOutputSize(const cv::Size& outputSize)
{
  if (outputSize.height < 2 || outputSize.width != 2 * outputSize.height)
  {
    throw std::invalid_argument("Dual-fisheye stitcher: the output panorama is " +
      sizeText(outputSize) +
      " but an equirectangular panorama must be twice as wide as high (e.g. 512x256).");
  }
}

// Median of values (reordered), by std::nth_element: OpenCV has no median of a vector.
float median(std::vector<float>& values)
{
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}
}

int DualFisheyeStitcher::recommendedReductionFactor(
  const FisheyeCalibration& calibration, const cv::Size& frameSize, const cv::Size& outputSize)
{
  validateOutputSize(outputSize);
  const FisheyeLensD front = makeFisheyeLens(calibration, false, frameSize);
  const FisheyeLensD back = makeFisheyeLens(calibration, true, frameSize);
  // Frame pixels per radian at the image centre (dr/dtheta = f there for all three models)
  // against output pixels per radian at the equator.
  const double framePixelsPerRadian = std::min(front.FocalLength, back.FocalLength);
  const double outputPixelsPerRadian = outputSize.width / (2.0 * PiD);
  // Keep the reduced frame at least twice as fine as the panorama: bilinear samples of a
  // 2x oversampled frame then average about one output pixel, like cv::resize INTER_AREA to
  // the panorama would, without the extra blur of a coarser frame.
  const double ratio = framePixelsPerRadian / outputPixelsPerRadian / 2.0;
  int factor = 1;
  while (2.0 * factor <= ratio && factor < 64)
  {
    factor *= 2;
  }
  return factor;
}

cv::Size reducedFrameSize(const cv::Size& frameSize, int factor)
{
  cv::Size size = frameSize;
  for (int f = factor; f > 1; f /= 2)
  {
    size = cv::Size(std::max(1, static_cast<int>(std::lround(0.5 * size.width))),
      std::max(1, static_cast<int>(std::lround(0.5 * size.height))));
  }
  return size;
}

void reduceFrame(const cv::Mat& frame, cv::Mat& reduced, int factor)
{
  if (factor < 1 || (factor & (factor - 1)) != 0)
  {
    throw std::invalid_argument(
      "reduceFrame: the factor must be a power of two, not " + std::to_string(factor) + ".");
  }
  if (factor == 1)
  {
    frame.copyTo(reduced);
    return;
  }
  // The last halving writes into `reduced`, so a caller's buffer is reused between frames.
  cv::Mat current = frame;
  for (int f = factor; f > 2; f /= 2)
  {
    cv::Mat half;
    cv::resize(current, half, reducedFrameSize(current.size(), 2), 0.0, 0.0, cv::INTER_AREA);
    current = half;
  }
  cv::resize(current, reduced, reducedFrameSize(current.size(), 2), 0.0, 0.0, cv::INTER_AREA);
}

void DualFisheyeStitcher::configure(const FisheyeCalibration& calibration,
  const cv::Size& frameSize, const cv::Size& outputSize, const DualFisheyeStitcherOptions& options)
{
  validateOutputSize(outputSize);
  validateCalibration(calibration);
  if (!(options.SaturationLevel > options.DarkLevel) || options.MinimumMatchSamples < 1 ||
    options.MaximumMatchPixels < options.MinimumMatchSamples)
  {
    throw std::invalid_argument("Dual-fisheye stitcher: SaturationLevel must exceed DarkLevel, "
                                "and MaximumMatchPixels >= MinimumMatchSamples >= 1.");
  }
  // Checks the aspect ratio too.
  makeFisheyeLens(calibration, false, frameSize);

  if (options.ReductionFactor < 0 || (options.ReductionFactor & (options.ReductionFactor - 1)) != 0)
  {
    throw std::invalid_argument("Dual-fisheye stitcher: ReductionFactor must be 0 (automatic) "
                                "or a power of two.");
  }
  const int reduction = options.ReductionFactor > 0 ? options.ReductionFactor
    : options.PrefilterLargeInput ? recommendedReductionFactor(calibration, frameSize, outputSize)
                                  : 1;
  const cv::Size workingSize = reducedFrameSize(frameSize, reduction);
  const FisheyeLensD lenses[2] = { makeFisheyeLens(calibration, false, workingSize),
    makeFisheyeLens(calibration, true, workingSize) };
  const FisheyeLensCalibration* lensCalibrations[2] = { &calibration.Front, &calibration.Back };

  // Keep bilinear footprints (and some compression blur) off the dark surround: a sample is
  // "safe" 1.5 working pixels inside the edge of the field of view.
  const double margins[2] = { edgeAngleOfPixels(lenses[0], 1.5),
    edgeAngleOfPixels(lenses[1], 1.5) };
  // Overlap width along the seam: the two half-fields minus the angle between the axes.
  const glm::dvec3 frontAxis = glm::transpose(lenses[0].CameraToLens) * glm::dvec3(0, 0, 1);
  const glm::dvec3 backAxis = glm::transpose(lenses[1].CameraToLens) * glm::dvec3(0, 0, 1);
  const double axisAngle = std::acos(std::clamp(glm::dot(frontAxis, backAxis), -1.0, 1.0));
  const double overlap = lenses[0].MaxTheta + lenses[1].MaxTheta - axisAngle;
  const double band = std::clamp(calibration.Stitching.BlendBandDegrees * DegreesToRadians, 0.0,
    std::max(0.0, overlap - 2.0 * std::max(margins[0], margins[1])));

  struct Sample
  {
    float X, Y;
    int Pixel;
    std::uint8_t Lens;
    float Blend, Vignetting;
  };
  std::vector<Sample> samples;
  samples.reserve(static_cast<std::size_t>(outputSize.area()) * 9 / 8);
  struct OverlapPixel
  {
    int Pixel;
    float FrontVignetting, BackVignetting;
  };
  std::vector<OverlapPixel> overlapPixels;
  cv::Mat overlapMask = cv::Mat::zeros(outputSize, CV_8UC1);
  cv::Mat frontBlend = cv::Mat::zeros(outputSize, CV_32FC1);

  for (int y = 0; y < outputSize.height; ++y)
  {
    for (int x = 0; x < outputSize.width; ++x)
    {
      const int outputRow = options.PanoramaBottomUp ? outputSize.height - 1 - y : y;
      const int pixel = outputRow * outputSize.width + x;
      const glm::dvec3 direction =
        panoramaDirection((x + 0.5) / outputSize.width, (y + 0.5) / outputSize.height);
      glm::dvec2 positions[2];
      double edgeDistance[2];
      double inverseFalloff[2];
      for (int l = 0; l < 2; ++l)
      {
        const glm::dvec3 local = lenses[l].CameraToLens * direction;
        fisheyeProject(lenses[l], local, positions[l]);
        edgeDistance[l] = lenses[l].MaxTheta - std::atan2(std::hypot(local.x, local.y), local.z);
        const double rho =
          glm::length(positions[l] - glm::dvec2(lenses[l].CenterX, lenses[l].CenterY)) /
          lenses[l].CircleRadius;
        inverseFalloff[l] = 1.0 / std::max(vignettingFalloff(*lensCalibrations[l], rho), 0.05);
      }
      auto addSample = [&](int l, double blend)
      {
        const double row =
          options.FrameBottomUp ? workingSize.height - 1 - positions[l].y : positions[l].y;
        samples.push_back({ static_cast<float>(positions[l].x), static_cast<float>(row), pixel,
          static_cast<std::uint8_t>(l), static_cast<float>(blend),
          static_cast<float>(inverseFalloff[l]) });
      };
      const bool safe[2] = { edgeDistance[0] >= margins[0], edgeDistance[1] >= margins[1] };
      const bool seen[2] = { edgeDistance[0] >= 0.0, edgeDistance[1] >= 0.0 };
      if (safe[0] && safe[1])
      {
        // Feathered blend across the band centred on e_front = e_back. Both samples are
        // kept even where one weight is 0: gain matching compares them over the whole band.
        const double blend = band > 0.0
          ? smoothstep((edgeDistance[0] - edgeDistance[1] + band) / (2.0 * band))
          : (edgeDistance[0] >= edgeDistance[1] ? 1.0 : 0.0);
        addSample(0, blend);
        addSample(1, 1.0 - blend);
        overlapPixels.push_back(
          { pixel, static_cast<float>(inverseFalloff[0]), static_cast<float>(inverseFalloff[1]) });
        overlapMask.at<std::uint8_t>(y, x) = 255;
        frontBlend.at<float>(y, x) = static_cast<float>(blend);
      }
      else if (seen[0] || seen[1])
      {
        // One lens, or a thin overlap: the lens farther inside its field, alone.
        const int main =
          (seen[0] && (!seen[1] || edgeDistance[0] - margins[0] >= edgeDistance[1] - margins[1]))
          ? 0
          : 1;
        addSample(main, 1.0);
        frontBlend.at<float>(y, x) = main == 0 ? 1.0f : 0.0f;
      }
      // Otherwise neither field of view covers it (lenses narrower than 180 degrees): black.
    }
  }

  // Frame-memory order: by row of the upper bilinear tap, then by column.
  std::vector<long long> keys(samples.size());
  std::vector<int> order(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i)
  {
    keys[i] = static_cast<long long>(std::floor(samples[i].Y)) * (workingSize.width + 2) +
      static_cast<long long>(std::floor(samples[i].X));
    order[i] = static_cast<int>(i);
  }
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return keys[a] < keys[b]; });

  // A 2D map keeps cv::remap's row-parallel split useful when it may use several threads.
  const int count = static_cast<int>(samples.size());
  const int columns = std::max(1, std::min(count, 1024));
  const int rows = std::max(1, (count + columns - 1) / columns);
  cv::Mat map(rows, columns, CV_32FC2, cv::Scalar::all(NoSample));
  std::vector<int> sortedIndex(samples.size());
  std::vector<int> samplePixel(samples.size());
  std::vector<std::uint8_t> sampleLens(samples.size());
  std::vector<float> sampleBlend(samples.size());
  std::vector<float> sampleWeight(samples.size());
  for (int k = 0; k < count; ++k)
  {
    const Sample& sample = samples[order[k]];
    sortedIndex[order[k]] = k;
    map.ptr<cv::Vec2f>()[k] = cv::Vec2f(sample.X, sample.Y);
    samplePixel[k] = sample.Pixel;
    sampleLens[k] = sample.Lens;
    sampleBlend[k] = sample.Blend;
    sampleWeight[k] = sample.Blend * sample.Vignetting;
  }
  // Fixed-point tables: cv::remap converts float maps to this form block by block on every
  // call anyway, so converting once saves that work.
  cv::Mat sampleMap, sampleMapFraction;
  cv::convertMaps(map, cv::noArray(), sampleMap, sampleMapFraction, CV_16SC2);

  // Overlap pixels were added with their front sample then their back sample; spread the
  // matching subset evenly over the band.
  std::vector<int> overlapFirstSample;
  for (int i = 0; i + 1 < count; ++i)
  {
    if (samples[i].Pixel == samples[i + 1].Pixel)
    {
      overlapFirstSample.push_back(i);
      ++i;
    }
  }
  const std::size_t matchCount =
    std::min(overlapFirstSample.size(), static_cast<std::size_t>(options.MaximumMatchPixels));
  std::vector<int> matchFront, matchBack;
  std::vector<float> matchFrontVignetting, matchBackVignetting;
  for (std::size_t m = 0; m < matchCount; ++m)
  {
    const std::size_t o = m * overlapFirstSample.size() / matchCount;
    const int first = overlapFirstSample[o];
    matchFront.push_back(sortedIndex[first]);
    matchBack.push_back(sortedIndex[first + 1]);
    matchFrontVignetting.push_back(overlapPixels[o].FrontVignetting);
    matchBackVignetting.push_back(overlapPixels[o].BackVignetting);
  }

  // Only now, with nothing left to throw, replace the previous configuration.
  this->SampleMap = sampleMap;
  this->SampleMapFraction = sampleMapFraction;
  this->SampleCount = count;
  this->SamplePixel = std::move(samplePixel);
  this->SampleLens = std::move(sampleLens);
  this->SampleBlend = std::move(sampleBlend);
  this->SampleWeight = std::move(sampleWeight);
  this->MatchFrontSample = std::move(matchFront);
  this->MatchBackSample = std::move(matchBack);
  this->MatchFrontVignetting = std::move(matchFrontVignetting);
  this->MatchBackVignetting = std::move(matchBackVignetting);
  this->Overlap = overlapMask;
  this->FrontBlend = frontBlend;
  this->Calibration = calibration;
  this->Options = options;
  this->FrameSize = frameSize;
  this->WorkingSize = workingSize;
  this->OutputSize = outputSize;
  this->Reduction = reduction;
  this->EffectiveBand = band / DegreesToRadians;
  this->resetGainMatching();
}

void DualFisheyeStitcher::resetGainMatching()
{
  this->GainRatio = { { 1.0, 1.0, 1.0 } };
  this->HasGainEstimate = false;
  this->MatchSamples = 0;
}

void DualFisheyeStitcher::remapFrame(const cv::Mat& frame)
{
  if (!this->isConfigured())
  {
    throw std::logic_error("DualFisheyeStitcher::stitch() called before configure().");
  }
  if (frame.type() != CV_32FC3 || frame.size() != this->FrameSize)
  {
    throw std::invalid_argument("Dual-fisheye stitcher: expected a linear CV_32FC3 frame of " +
      sizeText(this->FrameSize) + ", got " + sizeText(frame.size()) + " with " +
      std::to_string(frame.channels()) + " channel(s) of depth " + std::to_string(frame.depth()) +
      "; linearise 8/16-bit frames first and configure() for the frame size in use.");
  }
  const cv::Mat* source = &frame;
  if (this->Reduction > 1)
  {
    reduceFrame(frame, this->Reduced, this->Reduction);
    source = &this->Reduced;
  }
  cv::remap(*source, this->Samples, this->SampleMap, this->SampleMapFraction, cv::INTER_LINEAR,
    cv::BORDER_CONSTANT, cv::Scalar::all(0));
}

void DualFisheyeStitcher::estimateGain()
{
  if (!this->Calibration.Stitching.AutomaticGainMatching || this->MatchFrontSample.empty())
  {
    return;
  }
  const FisheyeLensCalibration* lenses[2] = { &this->Calibration.Front, &this->Calibration.Back };
  float calibratedRatio[3];
  for (int c = 0; c < 3; ++c)
  {
    calibratedRatio[c] = static_cast<float>((lenses[0]->ExposureGain * lenses[0]->WhiteBalance[c]) /
      (lenses[1]->ExposureGain * lenses[1]->WhiteBalance[c]));
  }
  const float dark = static_cast<float>(this->Options.DarkLevel);
  const float saturated = static_cast<float>(this->Options.SaturationLevel);
  for (auto& ratios : this->Ratios)
  {
    ratios.clear();
  }
  const cv::Vec3f* values = this->Samples.ptr<cv::Vec3f>();
  for (std::size_t m = 0; m < this->MatchFrontSample.size(); ++m)
  {
    const cv::Vec3f& front = values[this->MatchFrontSample[m]];
    const cv::Vec3f& back = values[this->MatchBackSample[m]];
    bool usable = true;
    for (int c = 0; c < 3; ++c)
    {
      usable =
        usable && front[c] > dark && front[c] < saturated && back[c] > dark && back[c] < saturated;
    }
    if (!usable)
    {
      continue;
    }
    const float vignetting = this->MatchBackVignetting[m] / this->MatchFrontVignetting[m];
    for (int c = 0; c < 3; ++c)
    {
      // The median of ratios is exp(median of log ratios) (the log is monotonic), so the
      // logs are only taken of the three medians.
      this->Ratios[c].push_back(back[c] / front[c] * vignetting * calibratedRatio[c]);
    }
  }
  this->MatchSamples = static_cast<int>(this->Ratios[0].size());
  if (this->MatchSamples < this->Options.MinimumMatchSamples)
  {
    return;
  }
  const double smoothing = this->HasGainEstimate ? this->Calibration.Stitching.GainSmoothing : 0.0;
  for (int c = 0; c < 3; ++c)
  {
    const double estimate = median(this->Ratios[c]);
    this->GainRatio[c] =
      std::exp(smoothing * std::log(this->GainRatio[c]) + (1.0 - smoothing) * std::log(estimate));
  }
  this->HasGainEstimate = true;
}

void DualFisheyeStitcher::accumulate(cv::Mat& panorama) const
{
  const FisheyeLensCalibration* lenses[2] = { &this->Calibration.Front, &this->Calibration.Back };
  const bool matched = this->Calibration.Stitching.AutomaticGainMatching;
  float gain[2][3];
  for (int l = 0; l < 2; ++l)
  {
    for (int c = 0; c < 3; ++c)
    {
      const double match = (l == 1 && matched) ? this->GainRatio[c] : 1.0;
      gain[l][c] =
        static_cast<float>(1.0 / (lenses[l]->ExposureGain * lenses[l]->WhiteBalance[c] * match));
    }
  }
  if (!panorama.isContinuous())
  {
    panorama.release(); // a caller's ROI: the scatter below indexes a continuous image
  }
  panorama.create(this->OutputSize, CV_32FC3);
  panorama.setTo(cv::Scalar::all(0));
  // A scatter-add of weighted samples (weight x per-lens colour gain): no OpenCV call
  // scatters through an index table.
  cv::Vec3f* out = panorama.ptr<cv::Vec3f>();
  const cv::Vec3f* values = this->Samples.ptr<cv::Vec3f>();
  for (int k = 0; k < this->SampleCount; ++k)
  {
    const float w = this->SampleWeight[k];
    const float* g = gain[this->SampleLens[k]];
    const cv::Vec3f& v = values[k];
    cv::Vec3f& target = out[this->SamplePixel[k]];
    target[0] += v[0] * (w * g[0]);
    target[1] += v[1] * (w * g[1]);
    target[2] += v[2] * (w * g[2]);
  }
}

void DualFisheyeStitcher::stitch(const cv::Mat& frame, cv::Mat& panorama)
{
  this->remapFrame(frame);
  this->estimateGain();
  this->accumulate(panorama);
}

void DualFisheyeStitcher::stitchEncoded(
  const cv::Mat& frame, const cv::Mat& response, cv::Mat& panorama)
{
  if (!this->isConfigured())
  {
    throw std::logic_error("DualFisheyeStitcher::stitchEncoded() called before configure().");
  }
  if (frame.type() != CV_8UC3 || frame.size() != this->FrameSize)
  {
    throw std::invalid_argument("Dual-fisheye stitcher: stitchEncoded() expects an 8-bit RGB "
                                "(CV_8UC3) frame of " +
      sizeText(this->FrameSize) + ", got " + sizeText(frame.size()) + " of type " +
      std::to_string(frame.type()) + ".");
  }
  if (response.total() != 256 || response.depth() != CV_32F ||
    (response.channels() != 1 && response.channels() != 3))
  {
    throw std::invalid_argument("Dual-fisheye stitcher: the camera response must be a 256-entry "
                                "CV_32FC1 (or per-channel CV_32FC3) table of linear values.");
  }
  const cv::Mat* source = &frame;
  if (this->Reduction > 1)
  {
    reduceFrame(frame, this->Reduced, this->Reduction);
    source = &this->Reduced;
  }
  // Interpolate the codes, then linearise only the samples: the whole frame is never
  // converted to float (5.5 MB read instead of 22 MB written and read for 1920x960).
  cv::remap(*source, this->EncodedSamples, this->SampleMap, this->SampleMapFraction,
    cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  cv::LUT(this->EncodedSamples, response.reshape(response.channels(), 1), this->Samples);
  this->estimateGain();
  this->accumulate(panorama);
}

void DualFisheyeStitcher::remapMask(const cv::Mat& mask, cv::Mat& panoramaMask)
{
  if (!this->isConfigured())
  {
    throw std::logic_error("DualFisheyeStitcher::remapMask() called before configure().");
  }
  if (mask.size() != this->FrameSize || (mask.depth() != CV_8U && mask.depth() != CV_32F) ||
    (mask.channels() != 1 && mask.channels() != 3))
  {
    throw std::invalid_argument("Dual-fisheye stitcher: the saturation mask must be CV_8UC1/C3 "
                                "or CV_32FC1/C3 of the frame's size " +
      sizeText(this->FrameSize) + ".");
  }
  const cv::Mat* source = &mask;
  if (this->Reduction > 1)
  {
    reduceFrame(mask, this->ReducedSaturation, this->Reduction);
    source = &this->ReducedSaturation;
  }
  cv::remap(*source, this->SaturationSamples, this->SampleMap, this->SampleMapFraction,
    cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  // The clipped fraction of each pixel's footprint (per sample the largest over the mask's
  // channels), blended with the radiance's weights (without the vignetting correction).
  cv::Mat fraction = cv::Mat::zeros(this->OutputSize, CV_32FC1);
  float* out = fraction.ptr<float>();
  const int channels = mask.channels();
  const bool bytes = mask.depth() == CV_8U;
  const std::uint8_t* byteValues = this->SaturationSamples.ptr<std::uint8_t>();
  const float* floatValues = this->SaturationSamples.ptr<float>();
  const float scale = bytes ? 1.0f / 255.0f : 1.0f;
  for (int k = 0; k < this->SampleCount; ++k)
  {
    float value = 0.0f;
    for (int c = 0; c < channels; ++c)
    {
      const int i = k * channels + c;
      value = std::max(value, bytes ? static_cast<float>(byteValues[i]) : floatValues[i]);
    }
    out[this->SamplePixel[k]] += this->SampleBlend[k] * value * scale;
  }
  fraction.convertTo(panoramaMask, mask.depth(), bytes ? 255.0 : 1.0);
}

void DualFisheyeStitcher::stitch(
  const cv::Mat& frame, const cv::Mat& saturation, cv::Mat& panorama, cv::Mat& panoramaSaturation)
{
  this->stitch(frame, panorama);
  this->remapMask(saturation, panoramaSaturation);
}

cv::Mat DualFisheyeStitcher::overlapMask() const
{
  return this->Overlap.clone();
}

cv::Mat DualFisheyeStitcher::frontWeight() const
{
  return this->FrontBlend.clone();
}

cv::Mat renderDualFisheye(const cv::Mat& linearPanorama, const FisheyeCalibration& calibration,
  const cv::Size& frameSize, int supersampling)
{
  if (linearPanorama.type() != CV_32FC3 || linearPanorama.rows < 2 ||
    linearPanorama.cols != 2 * linearPanorama.rows)
  {
    throw std::invalid_argument("renderDualFisheye: the panorama must be a linear CV_32FC3 "
                                "equirectangular image twice as wide as high.");
  }
  if (supersampling < 1 || supersampling > 16)
  {
    throw std::invalid_argument("renderDualFisheye: supersampling must lie in [1, 16].");
  }
  const FisheyeLensD lenses[2] = { makeFisheyeLens(calibration, false, frameSize),
    makeFisheyeLens(calibration, true, frameSize) };
  const FisheyeLensCalibration* lensCalibrations[2] = { &calibration.Front, &calibration.Back };

  // Subsamples are 1 / (f n) radians apart at the image centre; a panorama much finer than
  // that would alias through bilinear lookups, so box-filter it to about twice that density.
  cv::Mat panorama = linearPanorama;
  const double finest = std::max(lenses[0].FocalLength, lenses[1].FocalLength) * supersampling;
  const int neededHeight = static_cast<int>(std::ceil(2.0 * PiD * finest));
  if (panorama.rows > 2 * neededHeight)
  {
    cv::resize(
      linearPanorama, panorama, cv::Size(2 * neededHeight, neededHeight), 0.0, 0.0, cv::INTER_AREA);
  }
  // Pad so bilinear lookups wrap in longitude and cross the poles (the row above the top
  // row is the top row half a turn away).
  constexpr int Pad = 2;
  const int width = panorama.cols;
  const int height = panorama.rows;
  cv::Mat wrapped;
  cv::copyMakeBorder(panorama, wrapped, 0, 0, Pad, Pad, cv::BORDER_WRAP);
  cv::Mat padded(height + 2 * Pad, width + 2 * Pad, CV_32FC3);
  wrapped.copyTo(padded.rowRange(Pad, Pad + height));
  for (int i = 0; i < Pad; ++i)
  {
    const int shift = width / 2;
    for (int x = 0; x < width + 2 * Pad; ++x)
    {
      const int source = ((x - Pad + shift) % width + width) % width + Pad;
      padded.at<cv::Vec3f>(Pad - 1 - i, x) = wrapped.at<cv::Vec3f>(i, source);
      padded.at<cv::Vec3f>(Pad + height + i, x) = wrapped.at<cv::Vec3f>(height - 1 - i, source);
    }
  }

  cv::Mat frame = cv::Mat::zeros(frameSize, CV_32FC3);
  const int halfWidth = frameSize.width / 2;
  for (int l = 0; l < 2; ++l)
  {
    const FisheyeLensD& lens = lenses[l];
    const int x0 = lens.CenterX < halfWidth ? 0 : halfWidth;
    const cv::Rect half(
      x0, 0, (x0 == 0 ? halfWidth : frameSize.width - halfWidth), frameSize.height);
    cv::Mat accumulated = cv::Mat::zeros(half.size(), CV_32FC3);
    cv::Mat map(half.size(), CV_32FC2);
    cv::Mat sample;
    const glm::dmat3 lensToCamera = glm::transpose(lens.CameraToLens);
    const double reach = lens.CircleRadius + 2.0;
    for (int sy = 0; sy < supersampling; ++sy)
    {
      for (int sx = 0; sx < supersampling; ++sx)
      {
        const double offsetX = (sx + 0.5) / supersampling - 0.5;
        const double offsetY = (sy + 0.5) / supersampling - 0.5;
        for (int y = 0; y < half.height; ++y)
        {
          cv::Vec2f* row = map.ptr<cv::Vec2f>(y);
          for (int x = 0; x < half.width; ++x)
          {
            const glm::dvec2 pixel(x0 + x + offsetX, y + offsetY);
            glm::dvec3 local;
            if (glm::length(pixel - glm::dvec2(lens.CenterX, lens.CenterY)) > reach ||
              !fisheyeUnproject(lens, pixel, local))
            {
              row[x] = cv::Vec2f(NoSample, NoSample);
              continue;
            }
            const glm::dvec2 uv = panoramaCoordinates(lensToCamera * local);
            row[x] = cv::Vec2f(static_cast<float>(uv.x * width - 0.5 + Pad),
              static_cast<float>(uv.y * height - 0.5 + Pad));
          }
        }
        cv::remap(padded, sample, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
          cv::Scalar::all(0));
        accumulated += sample;
      }
    }
    // Photometric model of FisheyeCalibration.h, at the pixel centre (V varies too slowly
    // to matter within a pixel).
    const FisheyeLensCalibration& photometric = *lensCalibrations[l];
    const double n2 = static_cast<double>(supersampling) * supersampling;
    for (int y = 0; y < half.height; ++y)
    {
      cv::Vec3f* row = accumulated.ptr<cv::Vec3f>(y);
      for (int x = 0; x < half.width; ++x)
      {
        const double rho = std::hypot(x0 + x - lens.CenterX, y - lens.CenterY) / lens.CircleRadius;
        const double factor =
          std::max(vignettingFalloff(photometric, rho), 0.0) * photometric.ExposureGain / n2;
        for (int c = 0; c < 3; ++c)
        {
          row[x][c] = static_cast<float>(row[x][c] * factor * photometric.WhiteBalance[c]);
        }
      }
    }
    accumulated.copyTo(frame(half));
  }
  return frame;
}
}
}
