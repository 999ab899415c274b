// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_lighting_DualFisheyeStitcher_h
#define hv_lighting_DualFisheyeStitcher_h

#include "hv/lighting/FisheyeCalibration.h"

#include <opencv2/core.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace hv
{
namespace lighting
{
struct DualFisheyeStitcherOptions
{
  // Frames much finer than the panorama alias when sampled bilinearly. With this on, the
  // stitcher box-filters them (reduceFrame()) by recommendedReductionFactor() before
  // sampling. For 8-bit frames stitchEncoded() is much cheaper than linearising whole frames;
  // so is reducing the 8-bit frame before linearising it (reduceFrame() on the encoded frame,
  // the camera response on the small one, configure() for the reduced size: the calibration
  // is scaled to any frame size of the same aspect ratio), at the price that averaging
  // encoded values underestimates radiance where bright and dark pixels mix.
  bool PrefilterLargeInput = true;
  // A power of two to reduce by instead of recommendedReductionFactor() (0: that one).
  int ReductionFactor = 0;
  // Row order of the frames handed to stitch() and of the panoramas it writes: bottom row
  // first (VTK's image order) instead of OpenCV's top row first, so that VTK adapters need
  // not flip whole frames. overlapMask() and frontWeight() are always top row first.
  bool FrameBottomUp = false;
  bool PanoramaBottomUp = false;
  // Gain matching uses overlap pixels whose sensor values (linear, 1 = clipping) lie in
  // (DarkLevel, SaturationLevel) in every channel of both lenses.
  double SaturationLevel = 0.95;
  double DarkLevel = 0.005;
  // Fewer usable overlap pixels than this keep the previous gain estimate.
  int MinimumMatchSamples = 64;
  // At most this many overlap pixels, spread evenly over the band, enter the median: its
  // statistical error is already far below 1 % with a few thousand.
  int MaximumMatchPixels = 4096;
};

// Dual-fisheye frame -> equirectangular panorama (camera frame, hv/Equirectangular.h
// parameterisation; the front lens looks along -Z, the back lens along +Z), in linear light.
//
// configure() precomputes, once per calibration and size, a fixed-point remap table
// (cv::convertMaps, CV_16SC2) of every sample the panorama needs (one lens per pixel, both
// in the overlap band), with weights that fold in the feathered blend and the vignetting
// correction. stitch() is then one cv::remap plus one pass that adds the weighted samples
// into the panorama with the per-lens gains (calibrated exposure and white balance, and the
// automatically matched back/front gain).
//
// Feathered blend: with e_f, e_b the angles from a direction to the edges of the two
// fields of view, the front weight is smoothstep((e_f - e_b + B) / (2 B)) for an effective
// band B (BlendBandDegrees clamped to the overlap, less the bilinear footprint at the circle
// edges), so the seam runs where both lenses are equally far from their edges, and weights
// are 0 or 1 outside the band.
class DualFisheyeStitcher
{
public:
  // Throws std::invalid_argument for an invalid calibration, a frame size with another
  // aspect ratio than the calibration's, or an output that is not W x W/2.
  void configure(const FisheyeCalibration& calibration, const cv::Size& frameSize,
    const cv::Size& outputSize = cv::Size(512, 256),
    const DualFisheyeStitcherOptions& options = DualFisheyeStitcherOptions());
  bool isConfigured() const { return !this->SampleMap.empty(); }

  const FisheyeCalibration& calibration() const { return this->Calibration; }
  const DualFisheyeStitcherOptions& options() const { return this->Options; }
  cv::Size frameSize() const { return this->FrameSize; }
  cv::Size outputSize() const { return this->OutputSize; }
  // The size the tables sample: frameSize reduced by reductionFactor().
  cv::Size workingFrameSize() const { return this->WorkingSize; }
  int reductionFactor() const { return this->Reduction; }
  // The blend band actually used after clamping to the overlap, in degrees.
  double effectiveBlendBandDegrees() const { return this->EffectiveBand; }

  // The largest power-of-two factor by which a frame of frameSize can be reduced while a frame
  // pixel at the image centre stays at most half an output pixel at the equator (1 for frames
  // less than 4x finer than the panorama). On the blender-data panoramas rendered into
  // 1920x960 frames, reducing those by 2 as well cost 8-16 dB of round-trip PSNR (blur), while
  // on white-noise detail it gained 5 dB (less aliasing); this rule sits between. Powers of two
  // because reduceFrame() then runs OpenCV's vectorised 2x2 INTER_AREA path (on 8-bit RGB a
  // halving is 9x faster than a reduction by 3).
  static int recommendedReductionFactor(
    const FisheyeCalibration& calibration, const cv::Size& frameSize, const cv::Size& outputSize);

  // frame: linear RGB CV_32FC3 of frameSize. panorama: CV_32FC3 of outputSize; a continuous
  // Mat of that size and type (also one wrapping someone else's memory) is written in place,
  // anything else is reallocated. Throws std::invalid_argument on another frame type or size.
  void stitch(const cv::Mat& frame, cv::Mat& panorama);
  // Also remaps a saturation mask of the frame (CV_8U: 0 or 255, or CV_32F: 0 or 1, non-zero
  // where the sensor clipped; 1 channel, or 3 per-channel masks such as cv::threshold of the
  // RGB frame gives, of which each sample takes the largest) into panoramaSaturation
  // (1 channel, same depth): the fraction of each panorama pixel's sensor footprint that was
  // clipped.
  void stitch(const cv::Mat& frame, const cv::Mat& saturation, cv::Mat& panorama,
    cv::Mat& panoramaSaturation);
  // The saturation-mask half of the call above, after any stitch.
  void remapMask(const cv::Mat& saturation, cv::Mat& panoramaSaturation);

  // The fast path for 8-bit frames: frame is display-referred CV_8UC3 RGB of frameSize,
  // response the camera response as a 256-entry table of linear values (CV_32FC1, or
  // CV_32FC3 per channel; 1 = full scale). The samples are interpolated in the encoded codes
  // and linearised alone, so the frame is never converted to float as a whole (1920x960:
  // about 1.1 ms on one core instead of 4.4-4.9 ms with a whole-frame cv::LUT). Two costs:
  // interpolating codes instead of radiance differs where neighbouring pixels differ strongly
  // (edges of lights), and cv::remap rounds the interpolated codes to 8 bits again (a round
  // trip of an 8-bit frame: 57 instead of 60 dB).
  void stitchEncoded(const cv::Mat& frame, const cv::Mat& response, cv::Mat& panorama);

  // Back lens gain relative to the front lens (per channel, after the calibrated gains) that
  // automatic matching divides out; {1, 1, 1} when matching is off or has no estimate yet.
  std::array<double, 3> backToFrontGain() const { return this->GainRatio; }
  // Overlap pixels used by the last estimate.
  int gainMatchSampleCount() const { return this->MatchSamples; }
  // Forgets the temporally smoothed gain estimate (after a cut, for instance).
  void resetGainMatching();

  // CV_8UC1 of outputSize: 255 where both lenses see the direction (the overlap band, where
  // blending and gain matching happen), 0 elsewhere.
  cv::Mat overlapMask() const;
  // CV_32FC1 of outputSize: the front lens's blend weight (1 - the back lens's where both
  // contribute; 0 where no lens sees the direction).
  cv::Mat frontWeight() const;

private:
  void remapFrame(const cv::Mat& frame);
  void estimateGain();
  void accumulate(cv::Mat& panorama) const;

  FisheyeCalibration Calibration;
  DualFisheyeStitcherOptions Options;
  cv::Size FrameSize;
  cv::Size WorkingSize;
  cv::Size OutputSize;
  int Reduction = 1;
  double EffectiveBand = 0.0;

  // Every sample that contributes to the panorama (one per pixel seen by one lens, two in
  // the overlap band), sorted by its position in the frame so that cv::remap streams through
  // the frame's memory instead of jumping between rows: a fixed-point map shaped
  // SampleRows x SampleColumns (padded with no-sample entries), and per sample its panorama
  // pixel, lens (0 front, 1 back), blend weight, and blend weight times vignetting correction.
  cv::Mat SampleMap;
  cv::Mat SampleMapFraction;
  int SampleCount = 0;
  std::vector<int> SamplePixel;
  std::vector<std::uint8_t> SampleLens;
  std::vector<float> SampleBlend;
  std::vector<float> SampleWeight;
  // Overlap pixels used for gain matching (at most MaximumMatchPixels, spread evenly): the
  // front and back sample of each, and their vignetting corrections.
  std::vector<int> MatchFrontSample;
  std::vector<int> MatchBackSample;
  std::vector<float> MatchFrontVignetting;
  std::vector<float> MatchBackVignetting;
  cv::Mat Overlap;    // CV_8UC1, 255 in the overlap band
  cv::Mat FrontBlend; // CV_32FC1

  // Working buffers, kept between frames.
  cv::Mat Reduced;
  cv::Mat Samples;
  cv::Mat EncodedSamples;
  cv::Mat ReducedSaturation;
  cv::Mat SaturationSamples;
  std::vector<float> Ratios[3];

  std::array<double, 3> GainRatio{ { 1.0, 1.0, 1.0 } };
  bool HasGainEstimate = false;
  int MatchSamples = 0;
};

// Box-filters a frame (any depth and channel count) by a power-of-two factor as successive
// halvings with cv::resize INTER_AREA (two 2x2 box averages are one 4x4 box average), to
// reducedFrameSize(). Throws std::invalid_argument if factor is not a power of two.
void reduceFrame(const cv::Mat& frame, cv::Mat& reduced, int factor);
// Each halving rounds odd sizes to the nearest integer.
cv::Size reducedFrameSize(const cv::Size& frameSize, int factor);

// The forward simulator of the stitcher: the linear dual-fisheye frame (CV_32FC3, RGB) that a
// camera with this calibration records of a linear camera-frame panorama (CV_32FC3, W x W/2).
// Each frame pixel averages supersampling^2 bilinear samples of the panorama (the panorama is
// first box-filtered with cv::resize INTER_AREA if it is much finer than the subsamples), is
// multiplied by the vignetting falloff, the exposure gain and the white balance, and is black
// outside the image circles.
cv::Mat renderDualFisheye(const cv::Mat& linearPanorama, const FisheyeCalibration& calibration,
  const cv::Size& frameSize, int supersampling = 3);
}
}

#endif
