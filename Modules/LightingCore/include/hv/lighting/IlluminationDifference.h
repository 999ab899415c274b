// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_lighting_IlluminationDifference_h
#define hv_lighting_IlluminationDifference_h

#include <opencv2/core.hpp>

namespace hv
{
namespace lighting
{
// How the per-patch similarities are reduced to one illumination difference T.
enum class IlluminationDifferenceMode
{
  // T = 1 - min_p SSIM_p: a strong change in any one patch means the lighting changed (the
  // paper's text; the default).
  LeastSimilarPatch,
  // T = 1 - max_p SSIM_p: the paper's Eq. 1 as printed. A change confined to a few patches leaves
  // the most similar patch untouched, so T stays near 0; kept for comparison.
  MostSimilarPatch
};

// The illumination difference T in [0, 1) between two HDR radiance maps Q(t-1) and Q(t)
// (equirectangular, CV_32FC3 linear, width = 2 x height), used by the denoiser to decide how
// much history to keep. The panorama is cut into a grid of PatchGrid x PatchGrid patches
// (PatchGrid columns of 360/N degrees by PatchGrid rows of 180/N degrees; N = 8 gives 64 x 32
// pixel patches at 512 x 256). On the floored, shifted log-luminance
//   l = log10(max(Y, LuminanceFloor) / LuminanceFloor),  Y = Rec. 709 luminance,
// whose values lie in the FIXED data range [0, D], D = log10(MaxLuminance / LuminanceFloor),
// the SSIM map of Wang et al. (2004) is evaluated with their Gaussian window (11 x 11,
// sigma = 1.5) and constants C1 = (0.01 D)^2, C2 = (0.03 D)^2; SSIM_p is the mean of the map
// over patch p, and T = 1 - min_p SSIM_p (or 1 - max_p SSIM_p), clamped to [0, MaxDifference].
// See Documentation/HDREstimation.md.
class IlluminationDifference
{
public:
  // T never reaches 1: the denoiser divides by (1 - T) in places, and T = 1 exactly would mean
  // "no history at all", which a fresh start already expresses as MaxDifference.
  static constexpr float MaxDifference = 1.0f - 1e-6f;

  struct Parameters
  {
    int PatchGrid = 8;            // N: patches per row and per column of the grid
    float LuminanceFloor = 0.01f; // relative radiance below which changes do not count
    float MaxLuminance = 1.0e4f;  // top of the fixed data range (relative radiance)
    IlluminationDifferenceMode Mode = IlluminationDifferenceMode::LeastSimilarPatch;
  };

  IlluminationDifference() = default;
  explicit IlluminationDifference(const Parameters& parameters);

  // Throws std::invalid_argument for PatchGrid < 1, a non-positive floor or MaxLuminance not
  // above the floor.
  void setParameters(const Parameters& parameters);
  const Parameters& parameters() const { return this->Params; }

  // T between two maps of the same size. Throws std::invalid_argument for empty, non-CV_32FC3,
  // non-2:1, differently sized or non-finite maps, or maps smaller than the grid.
  float compute(const cv::Mat& previous, const cv::Mat& current);

  // Streaming form: T between this map and the one given to the previous call. The first call
  // (and the first after reset() or a size change) has no valid history and returns
  // MaxDifference, which tells the denoiser to drop its history.
  float update(const cv::Mat& radiance);
  void reset();
  bool hasHistory() const { return this->HasHistory; }

  // The last result: T and the PatchGrid x PatchGrid CV_32F map of SSIM_p (row 0 = the patches at
  // the zenith). Empty before the first comparison.
  float difference() const { return this->Difference; }
  const cv::Mat& patchSimilarity() const { return this->PatchSimilarity; }

private:
  struct LogStatistics
  {
    cv::Mat Log;      // l
    cv::Mat Mean;     // G * l
    cv::Mat MeanOfSq; // G * l^2
  };
  void validate(const cv::Mat& radiance, const char* what, bool checkFinite) const;
  // l and its windowed moments for a radiance map; with the previous frame's statistics, also
  // the SSIM map between the two (Ssim).
  void logStatistics(const cv::Mat& radiance, LogStatistics& out, const LogStatistics* previous);
  void windowedMoments(LogStatistics& current, const LogStatistics* previous);
  // T from the SSIM map.
  float compare();

  Parameters Params;
  LogStatistics Previous;
  LogStatistics Current;
  cv::Mat Padded;         // one row of each signal, with reflected borders (+ one spare row)
  cv::Mat RowWindowed[3]; // ring of rows of the signals after the window's horizontal pass
  cv::Mat Ssim;           // the SSIM map, when the grid does not divide the panorama
  cv::Mat SsimRows;       // otherwise one row of it and the running sum of a block row's rows
  bool PatchesSummed = false;
  cv::Mat PatchSimilarity;
  float Difference = MaxDifference;
  bool HasHistory = false;
};
}
}

#endif
