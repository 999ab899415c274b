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
  // the restored regions. lights: one entry per detected region, the most powerful first.
  // Throws std::invalid_argument for bad input.
  void estimate(const cv::Mat& linear, const cv::Mat& saturationMask, cv::Mat& radiance,
    std::vector<DetectedLight>& lights);

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
  struct Bilinear // precomputed bilinear lookup into a patch; Index < 0: outside (zero)
  {
    int Index = -1;
    float Fx = 0.0f, Fy = 0.0f;
  };
  struct Sample
  {
    float PatchX, PatchY;     // position in the tangent patch (patch pixels)
    float TangentX, TangentY; // azimuthal-equidistant coordinates (radians)
    float Luminance;
    float Model;           // blurred support at the sample
    Bilinear Fine, Coarse; // lookups into the core-blurred and the (coarser) halo-blurred patch
    int Pixel;
    int Kind; // 0 fitted, 1 region (constraint), 3 guard band outside, 4 guard band inside
  };

  void validate(const cv::Mat& linear, const cv::Mat& mask) const;
  void prepareGeometry(int width, int height);
  void computeBrightness(const cv::Mat& linear);
  float statisticalThreshold(float mads);
  void findRegions(const cv::Mat& candidates, const cv::Mat& mask, float minPeak);
  void describe(const cv::Mat& q, const Region& region, DetectedLight& light) const;
  bool fitLight(
    const cv::Mat& linear, const cv::Mat& mask, int index, cv::Mat& q, DetectedLight& light);
  float evaluateSupport(float delta, float& radiance, double background[3], double& residual);

  Parameters Params;
  int Width = 0;
  int Height = 0;
  std::vector<float> RowSolidAngle, SinTheta, CosTheta, SinPhi, CosPhi;
  cv::Mat Luminance, Brightness, Candidates, ComponentLabels, Labels;
  std::vector<float> LogSamples;
  std::vector<int> Parent, RootArea, RegionOfRoot, RegionOfLabel; // per connected component
  std::vector<Region> Regions;
  float Threshold = 0.0f;

  // Per-light fitting buffers (reused between lights and frames).
  int PatchSize = 0;
  float PatchPitch = 0.0f;
  int HaloFactor = 1; // the halo is blurred on a patch HaloFactor times coarser
  cv::Mat CoreMask, InsideDistance, OutsideDistance, SignedDistance, Support, CoreBlur, HaloSupport,
    HaloBlur;
  std::vector<Sample> Samples; // [0, FitEnd) fitted, [FitEnd, ConstraintEnd) constraints, rest
  int FitEnd = 0;
  int ConstraintEnd = 0;
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
