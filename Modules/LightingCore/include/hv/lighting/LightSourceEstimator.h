// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_lighting_LightSourceEstimator_h
#define hv_lighting_LightSourceEstimator_h

#include "hv/Platform.h"

#include <opencv2/core.hpp>
#include <opencv2/core/matx.hpp>

#include <vector>

namespace hv
{
namespace lighting
{
// How the radiance of clipped regions is restored when composing the HDR map Q.
enum class ExpansionOperator
{
  // "LDR used as HDR": Q is the linearised panorama; clipped lights stay at the clip level.
  None,
  // Landis (2002) as in Banterle et al.'s HDR Toolbox: for luminance Y >= R (relative to the
  // clip level), k = ((Y - R) / (Ymax - R))^alpha and Y' = Y (1 - k) + M Y k. A classical
  // global expansion operator, kept as a baseline.
  Landis,
  // Per-light forward model (the default): each clipped region is a source of uniform unknown
  // radiance L on a support S (the clipped region eroded by delta), seen through the camera's
  // point-spread function (Gaussian core + Gaussian veiling-glare halo); L, delta and a local
  // background plane are fitted to the unclipped pixels around the region, constrained so that
  // the model reaches at least the observed value on every clipped pixel. A fit that does not
  // explain the surroundings (MinExplainedFraction) is declined and the region keeps its
  // observed values: the model needs the camera's calibrated glare to say anything.
  LightSourceModel
};

// A detected light source (a connected bright region of the panorama, merged across the u seam
// and over the poles).
struct DetectedLight
{
  glm::vec3 Direction = glm::vec3(0.0f, 1.0f, 0.0f); // unit, panorama frame (hv/Equirectangular.h)
  float SolidAngle = 0.0f;            // sr, sum of sin(theta) dtheta dphi over the region's pixels
  glm::vec3 Colour = glm::vec3(1.0f); // chromaticity of the source, Rec. 709 luminance 1
  float Intensity = 0.0f;             // mean luminance of Q over the region (relative radiance)
  glm::vec3 Radiance = glm::vec3(0.0f); // mean RGB of Q over the region
  float Peak = 0.0f;                    // largest luminance of Q in the region
  int PixelCount = 0;
  // Panorama pixels; a region that crosses the u seam has x + width > the panorama width (read
  // columns modulo the width).
  cv::Rect BoundingBox;
  // Power of the source, luminance x sr: SourceRadiance x SourceSolidAngle for LightSourceModel
  // (it includes the part of the light the camera's halo spreads outside the region), the
  // integral of Q's luminance over the region otherwise.
  float Power = 0.0f;
  float SourceRadiance = 0.0f;   // fitted uniform luminance L of the source (or Intensity)
  float SourceSolidAngle = 0.0f; // solid angle of the fitted support S (or SolidAngle)
  bool Clipped = false;          // the region held clipped pixels
  bool Estimated = false;        // its radiance was fitted by the light-source model
};

// Parameters of LightSourceEstimator; radiances are relative (1 = the sensor clip level at the
// reference exposure, as CameraResponse outputs).
struct LightSourceEstimatorParameters
{
  ExpansionOperator Operator = ExpansionOperator::LightSourceModel;

  // Detection (LDR, estimate()): a pixel is a light candidate when its brightest channel B
  // reaches NearClipFraction x ClipLevel or it is flagged in the saturation mask, and B also
  // reaches the statistical threshold exp(median(ln B) + ThresholdMads x 1.4826 MAD(ln B)).
  // ClipLevel: linear value at which the sensor clipped (1 / exposure scale when CameraResponse
  // divided the frame by its exposure scale). ThresholdMads = 0 (the default) turns the
  // statistical term off for LDR frames: with k = 4 it rose above the clip level and hid every
  // light in 6 of the 8 real test panoramas (high-contrast scenes have a wide MAD), and a
  // clipped pixel is evidence of a light whatever the statistics say.
  // Detection (HDR, detect()): B > exp(median(ln B) + HdrThresholdMads x 1.4826 MAD(ln B)).
  float ClipLevel = 1.0f;
  float NearClipFraction = 0.95f; // sRGB code 250 decodes to 0.956
  float ThresholdMads = 0.0f;
  float HdrThresholdMads = 4.0f;
  int MinPixelCount = 3; // smaller regions are noise or specks, not lights
  // LDR: a region is a light only if its brightest channel reaches MinPeakFraction x ClipLevel
  // somewhere (0.99: sRGB code 253); noise speckles on a surface just below the clip level
  // cross the near-clip threshold but seldom reach the top codes.
  float MinPeakFraction = 0.99f;
  int MaxFittedLights = 4; // the largest clipped regions are fitted (~0.4 ms each at 512 x 256)

  // The camera's point-spread function on the sphere (calibrate it, see the documentation):
  // a Gaussian core of PsfSigmaDegrees (lens + stitching resampling; the pixel footprint is
  // added by the estimator) and a veiling-glare halo holding HaloFraction of the energy, a
  // Gaussian of HaloSigmaDegrees.
  float PsfSigmaDegrees = 1.0f;
  float HaloFraction = 0.02f;
  float HaloSigmaDegrees = 5.0f;
  float MaxRadiance = 1.0e5f; // upper bound of a fitted source radiance (relative)
  // Model check: a fit is used only when it explains at least this fraction of the variance of
  // the unclipped surroundings left by a background plane; otherwise the region keeps its
  // observed (clip-level) values and is reported with Estimated = false.
  float MinExplainedFraction = 0.75f;

  // Landis (2002) expansion (ExpansionOperator::Landis).
  float LandisThreshold = 0.5f;    // R, relative to ClipLevel
  float LandisExponent = 2.0f;     // alpha
  float LandisMaxRadiance = 10.0f; // M: the gain of the brightest pixels (one decade)
};

// LDR -> HDR: detects light sources in a linear equirectangular panorama and recovers the
// radiance of their clipped cores, composing the HDR radiance map Q. See
// Documentation/HDREstimation.md for the model, its equations and its measured accuracy.
class LightSourceEstimator
{
public:
  using Parameters = LightSourceEstimatorParameters;

  LightSourceEstimator() = default;
  explicit LightSourceEstimator(const Parameters& parameters);

  // Throws std::invalid_argument for out-of-range values (the message names the field).
  void setParameters(const Parameters& parameters);
  const Parameters& parameters() const { return this->Params; }

  // linear: CV_32FC3 RGB, width = 2 x height, finite, from CameraResponse (or the stitcher).
  // saturationMask: empty, or CV_8UC1 of the same size, non-zero where the sensor clipped.
  // radiance (Q): CV_32FC3, same size, linear, same units as `linear`; equal to `linear` outside
  // the restored regions; it may be `linear` itself (Q is then composed in place, saving a copy).
  // lights: one entry per detected region, the most powerful first. radianceIsInput: when
  // given, and the light-source model restores no light (Q equals `linear`, the common case for
  // real scenes), `radiance` is left as it is and *radianceIsInput is true: the caller uses
  // `linear` as Q and no copy of the map is made. Throws std::invalid_argument for bad input.
  void estimate(const cv::Mat& linear, const cv::Mat& saturationMask, cv::Mat& radiance,
    std::vector<DetectedLight>& lights, bool* radianceIsInput = nullptr);

  // Scene-linear (HDR) input needs no estimation: detects its bright regions with the
  // statistical threshold only and describes them from the input itself.
  void detect(const cv::Mat& radiance, std::vector<DetectedLight>& lights);

  // The last call's region labels (CV_32S, 0 = none, i + 1 = lights[i]) and threshold on B.
  const cv::Mat& lightLabels() const { return this->Labels; }
  float detectionThreshold() const { return this->Threshold; }

private:
  struct Region
  {
    std::vector<int> Pixels; // indices y * width + x
    bool Clipped = false;
    float Peak = 0.0f; // largest brightest-channel value
  };
  // Bilinear lookups into a patch are stored as Index (of the top-left of the four pixels, -1:
  // outside the patch, value 0) and the fractions Fx, Fy.
  // Per pixel of a run of one panorama row: cos of the angle to the light, tangent coordinates,
  // the lookups into the fine and the coarse patch, and the signed distance to
  // the region there.
  struct TangentRowBuffers
  {
    std::vector<float> CosRho, TangentX, TangentY, Depth, FineFx, FineFy, CoarseFx, CoarseFy;
    std::vector<int> FineIndex, CoarseIndex;
    std::vector<uchar> Kind;     // the set the pixel joins, see fitLight()
    std::vector<int> Members[3]; // the run's pixels per set
    void resize(int count);
  };
  // Samples of one light's window (panorama pixels), one array per quantity so that the loops
  // run for every candidate support vectorise and stream only what they read.
  struct SampleSet
  {
    std::vector<float> TangentX, TangentY; // azimuthal-equidistant coordinates (radians)
    std::vector<float> Luminance;
    std::vector<float> Model; // blurred support at the sample
    // Lookups into the core- and the halo-blurred patch.
    std::vector<int> FineIndex, CoarseIndex;
    std::vector<float> FineFx, FineFy, CoarseFx, CoarseFy;
    std::vector<int> Pixel; // y * width + x
    int Count = 0;          // samples held (the arrays may be longer)
    int size() const { return this->Count; }
    void clear() { this->Count = 0; }
    // Appends the row run's pixels `members` (indices into the run).
    // rgb: the run's first pixel in the linear panorama.
    void append(const TangentRowBuffers& row, const int* members, int count, const float* rgb,
      int firstPixel);
  };

  // The light being fitted, in float for the per-pixel loop (tangentRow()).
  struct TangentFrame
  {
    glm::vec3 Centre, Axis1, Axis2; // c0, e1, e2
    float InversePitch = 1.0f;      // patch pixels per radian
    float PatchCentre = 0.0f;
    int PatchSize = 1;
    int HaloFactor = 1;
  };
  void validate(const cv::Mat& linear, const cv::Mat& mask) const;
  void tangentRow(int y, int first, int count);
  void prepareGeometry(int width, int height);
  void computeBrightness(const cv::Mat& linear);
  void markRowsWithCandidates();
  float statisticalThreshold(float mads);
  void findRegions(const cv::Mat& candidates, const cv::Mat& mask, float minPeak);
  void describe(const cv::Mat& q, const Region& region, DetectedLight& light) const;
  // qWritten: whether q holds the input yet (it is copied before the first write otherwise).
  bool fitLight(const cv::Mat& linear, const cv::Mat& mask, int index, cv::Mat& q, bool& qWritten,
    DetectedLight& light);
  float evaluateSupport(float delta, float& radiance, double background[3], double& residual);

  Parameters Params;
  int Width = 0;
  int Height = 0;
  std::vector<float> RowSolidAngle, SinTheta, CosTheta, SinPhi, CosPhi;
  cv::Mat Brightness, Candidates, ComponentBuffer, ComponentLabels, Labels;
  std::vector<uchar> RowHasCandidates; // per row of Candidates: any candidate pixel
  int LabelledRows[2] = { 0, 0 };      // the rows of Labels that may be non-zero
  std::vector<float> LogSamples;
  std::vector<int> Parent, RootArea, RegionOfRoot, RegionOfLabel; // per connected component
  std::vector<Region> Regions;
  mutable std::vector<char> ColumnScratch; // describe(): the columns a region covers
  float Threshold = 0.0f;

  // Per-light fitting buffers (reused between lights and frames).
  int PatchSize = 0;
  float PatchPitch = 0.0f;
  int HaloFactor = 1; // the halo is blurred on a patch HaloFactor times coarser
  cv::Mat RasterCandidates, CoreMask, OutsideMask, InsideDistance, OutsideDistance, SignedDistance,
    Support, CoreBlur, HaloSupport, HaloBlur, ModelPatch;
  cv::Mat CoreKernel, HaloKernel; // the Gaussians of evaluateSupport() for this light's patch
  TangentFrame Frame;
  TangentRowBuffers Row;
  SampleSet Fitted;             // unclipped surroundings: the fit
  SampleSet Constraints;        // the region's interior: the model must reach the observation
  SampleSet Interior;           // the region's guard band: part of the light, constrains nothing
  cv::Matx33d BackgroundNormal; // sum of (1, X, Y)(1, X, Y)^T over the fitted samples
  cv::Vec3d BackgroundRhs;      // sum of (1, X, Y) Y_obs
  double SumLuminanceSq = 0.0;
  std::vector<double> ScanResidual;
};

// The Landis (2002) expansion on its own (see ExpansionOperator::Landis); linear: CV_32FC3,
// threshold and the result relative to clipLevel.
void expandLandis(const cv::Mat& linear, cv::Mat& expanded, float clipLevel, float threshold,
  float exponent, float maxRadiance);
}
}

#endif
