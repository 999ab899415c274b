// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_lighting_FisheyeCalibration_h
#define hv_lighting_FisheyeCalibration_h

#include "hv/FisheyeLens.h"

#include <opencv2/core.hpp>

#include <array>
#include <string>
#include <vector>

namespace hv
{
namespace lighting
{
// Calibration of a dual-fisheye 360-degree camera and the options of its stitching.
// Documentation/FisheyeCalibration.md describes the JSON file, the lens models with their
// equations, the presets and a calibration procedure.
//
// Photometric model of one lens, in linear light, for a scene radiance L seen at normalised
// image radius rho = r / Radius (0 at the centre, 1 on the image circle):
//   pixel_c = ExposureGain * WhiteBalance_c * V(rho) * L_c,
//   V(rho) = 1 + a1 rho^2 + a2 rho^4 + a3 rho^6   (Vignetting = {a1, a2, a3}).
// The stitcher divides these factors out; renderDualFisheye() applies them.

// Which half of a side-by-side frame holds the front lens (the one looking along -Z).
enum class FrontHalf
{
  Left,
  Right
};

struct FisheyeLensCalibration
{
  FisheyeProjection Model = FisheyeProjection::Equidistant;
  // Image circle centre in pixels, measured from the top-left corner of the half of the frame
  // that holds this lens, at the calibration's frame size; pixel centres at integers (OpenCV).
  double CenterX = 0.0;
  double CenterY = 0.0;
  // Image circle radius in pixels: the radius at which the lens sees half its field of view.
  double Radius = 0.0;
  double FieldOfViewDegrees = 190.0;
  // Kannala-Brandt only: f in pixels (OpenCV's fx of cv::fisheye::calibrate); 0 derives it
  // from Radius and FieldOfViewDegrees, as the other two models always do.
  double FocalLength = 0.0;
  std::array<double, 4> KannalaBrandt{ { 0.0, 0.0, 0.0, 0.0 } };
  std::array<double, 3> Vignetting{ { 0.0, 0.0, 0.0 } };
  double ExposureGain = 1.0;
  std::array<double, 3> WhiteBalance{ { 1.0, 1.0, 1.0 } }; // R, G, B
  // Orientation in degrees on top of the nominal one (front: looking along -Z, back: turned
  // 180 degrees about +Y). The lens-to-camera rotation is
  //   Ry(nominal + Yaw) * Rx(Pitch) * Rz(Roll) * diag(1, -1, -1)
  // (right-handed rotations about the camera axes; diag(1, -1, -1) maps the lens frame
  // x right / y down / z forward onto the camera looking along -Z). The front lens defines
  // the camera frame, so its angles are normally 0 except for a sensor mounted turned by 90
  // degrees (Roll); the back lens's angles are its small mounting error.
  double YawDegrees = 0.0;
  double PitchDegrees = 0.0;
  double RollDegrees = 0.0;

  bool operator==(const FisheyeLensCalibration& other) const;
  bool operator!=(const FisheyeLensCalibration& other) const { return !(*this == other); }
};

struct StitchingOptions
{
  // Angular width of the feathered transition between the lenses, centred where both lenses
  // are equally far from the edge of their field of view. Clamped to the overlap of the two
  // fields of view (less a pixel-sized margin); 0 gives a hard seam.
  double BlendBandDegrees = 8.0;
  // Estimate the back lens's per-channel gain relative to the front lens from the overlap
  // band of every frame and divide it out before blending.
  bool AutomaticGainMatching = true;
  // Temporal smoothing of the estimated gain, in [0, 1): 0 uses each frame's estimate alone,
  // s blends log-gains as g_t = s g_{t-1} + (1 - s) estimate_t.
  double GainSmoothing = 0.0;

  bool operator==(const StitchingOptions& other) const;
  bool operator!=(const StitchingOptions& other) const { return !(*this == other); }
};

struct FisheyeCalibration
{
  static constexpr int SchemaVersion = 1;

  std::string CameraName;
  std::string Notes;
  // The frame size the centres and radii are measured at. Frames of another size with the
  // same aspect ratio (a reduced stream, say) are handled by scaling.
  int FrameWidth = 0;
  int FrameHeight = 0;
  // Only side-by-side frames (one lens per half) exist so far.
  FrontHalf FrontLensHalf = FrontHalf::Left;
  FisheyeLensCalibration Front;
  FisheyeLensCalibration Back;
  StitchingOptions Stitching;

  bool operator==(const FisheyeCalibration& other) const;
  bool operator!=(const FisheyeCalibration& other) const { return !(*this == other); }
};

// Throws std::invalid_argument naming the offending field (with its JSON key) when the
// calibration is unusable: non-positive sizes, a field of view outside (0, 250] degrees, a
// circle centre outside its half, a Kannala-Brandt polynomial that does not increase over
// the field of view, a vignetting falloff that is not positive, non-positive gains, ...
void validateCalibration(const FisheyeCalibration& calibration);

// JSON (schema in Documentation/FisheyeCalibration.md). fromJson/loadCalibration validate
// and throw std::invalid_argument (bad content, naming the key) or std::runtime_error
// (unreadable file, invalid JSON syntax) with a message that says what to fix.
std::string toJson(const FisheyeCalibration& calibration);
FisheyeCalibration fromJson(const std::string& json);
FisheyeCalibration loadCalibration(const std::string& path);
void saveCalibration(const FisheyeCalibration& calibration, const std::string& path);

// Built-in nominal calibrations ("insta360-one-x", "ricoh-theta"): starting points to refine
// with the calibration procedure. The same values are in Modules/LightingCore/presets/.
std::vector<std::string> calibrationPresetNames();
// Throws std::invalid_argument listing the known names when name is not one of them.
FisheyeCalibration presetCalibration(const std::string& name);

// The lens model for a frame of frameSize (which must have the calibration's aspect ratio):
// centre, radius and focal length scaled to that size and shifted to the lens's half,
// orientation from the nominal direction and the yaw/pitch/roll angles.
FisheyeLensD makeFisheyeLens(
  const FisheyeCalibration& calibration, bool backLens, const cv::Size& frameSize);

// Vignetting falloff V(rho) of a lens.
double vignettingFalloff(const FisheyeLensCalibration& lens, double rho);

// ---- Calibration helpers (the procedure in Documentation/FisheyeCalibration.md) ----

struct ImageCircle
{
  double CenterX = 0.0; // pixels in the half, like FisheyeLensCalibration::CenterX
  double CenterY = 0.0;
  double Radius = 0.0;
};

// Finds the image circle of one half of a frame of a bright, evenly lit scene: Otsu's
// threshold of the luminance, the largest lit blob, and a least-squares ellipse through its
// outline (cv::threshold, cv::findContours, cv::fitEllipse). frame: CV_8UC3, CV_16UC3 or
// CV_32FC3. Throws std::invalid_argument when no circle is found.
ImageCircle estimateImageCircle(const cv::Mat& frame, bool rightHalf);

// Least-squares fit of the vignetting polynomial {a1, a2, a3} from a linear frame of a flat
// field (a uniform, diffusely lit surface filling the lens, such as a white diffuser over it):
// V(rho) = pixel(rho) / pixel(0), with the lens's centre and radius from `lens`.
// Unsaturated pixels with rho <= maxRho are used. Throws when too few are usable.
std::array<double, 3> fitVignetting(const cv::Mat& linearFrame,
  const FisheyeCalibration& calibration, bool backLens, double maxRho = 0.98,
  double saturationLevel = 0.95);
}
}

#endif
