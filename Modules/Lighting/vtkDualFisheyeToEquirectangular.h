// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
/**
 * @class   vtkDualFisheyeToEquirectangular
 * @brief   Stitches a dual-fisheye camera frame into a linear equirectangular panorama.
 *
 * A thin adapter over hv::lighting::DualFisheyeStitcher. The input is a vtkImageData frame
 * (point scalars, VTK row order) from a 360-degree camera that records both lenses side by
 * side (usually 2:1). The output is the camera-frame panorama, W x W/2 (default 512 x 256),
 * with a 3-component float point array "Radiance" in linear light, in VTK's row order (j = 0
 * is the bottom row, the nadir), ready for the lighting filters downstream.
 *
 * Input conversions:
 * - unsigned char / unsigned short: display-referred sRGB, linearised with the sRGB EOTF
 *   (1 = the sensor's full scale), unless the field data string "Encoding" is "SceneLinear";
 * - float / double: scene-linear, unless "Encoding" is "DisplayReferred";
 * - 1 component (greyscale) is replicated into R, G, B; of 2 (grey + alpha) and 4 (RGBA)
 *   components the alpha is dropped; other component counts or scalar types are an error;
 * - NaN or infinite values are an error.
 * With ComputeClippedFraction on, for display-referred input the output also holds a float
 * point array "ClippedFraction": the fraction of each panorama pixel's sensor footprint where
 * some channel reached ClippingThreshold of full scale, for the HDR estimation downstream.
 *
 * The calibration comes from a JSON file (SetCalibrationFileName) or a built-in preset
 * (SetPreset, "insta360-one-x" or "ricoh-theta"); the file wins when both are set. See
 * Documentation/FisheyeCalibration.md. The input frame must have the calibration's aspect
 * ratio; its size may differ (a reduced stream): centres and radii are scaled.
 *
 * Remap tables are rebuilt only when a setting of this filter (calibration source, output
 * size, stitching settings) or the input frame size changes, not per frame. After editing a
 * calibration file in place, call ReloadCalibration().
 *
 * The input's field data is passed to the output, with "Encoding" kept as the input's (or
 * set from the scalar type when missing): it tells downstream filters whether the frame was
 * display-referred (clipped LDR: estimate the HDR radiance) or scene-linear.
 */

#ifndef vtkDualFisheyeToEquirectangular_h
#define vtkDualFisheyeToEquirectangular_h

#include "holoLightingModule.h" // For export macro
#include "vtkImageAlgorithm.h"

#include <memory> // For std::unique_ptr

class HOLOLIGHTING_EXPORT vtkDualFisheyeToEquirectangular : public vtkImageAlgorithm
{
public:
  static vtkDualFisheyeToEquirectangular* New();
  vtkTypeMacro(vtkDualFisheyeToEquirectangular, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /**
   * A calibration JSON file (Documentation/FisheyeCalibration.md). Takes precedence over
   * the preset.
   */
  vtkSetFilePathMacro(CalibrationFileName);
  vtkGetFilePathMacro(CalibrationFileName);
  ///@}

  ///@{
  /**
   * A built-in nominal calibration: "insta360-one-x" or "ricoh-theta".
   */
  vtkSetStringMacro(Preset);
  vtkGetStringMacro(Preset);
  ///@}

  /**
   * Read the calibration file again at the next update (after it was edited in place).
   */
  void ReloadCalibration();

  /**
   * The built-in presets.
   */
  static int GetNumberOfPresets();
  static const char* GetPresetName(int index);

  ///@{
  /**
   * Output panorama size (default 512 x 256); the width must be twice the height.
   */
  vtkSetVector2Macro(OutputDimensions, int);
  vtkGetVector2Macro(OutputDimensions, int);
  ///@}

  ///@{
  /**
   * Width in degrees of the feathered transition between the lenses; negative (the default)
   * uses the calibration's stitching.blendBandDegrees.
   */
  vtkSetMacro(BlendBandDegrees, double);
  vtkGetMacro(BlendBandDegrees, double);
  ///@}

  ///@{
  /**
   * Automatic exposure/white-balance matching of the back lens to the front lens from the
   * overlap band: 1 on, 0 off, -1 (the default) as the calibration's
   * stitching.automaticGainMatching says.
   */
  vtkSetClampMacro(AutomaticGainMatching, int, -1, 1);
  vtkGetMacro(AutomaticGainMatching, int);
  vtkBooleanMacro(AutomaticGainMatching, int);
  ///@}

  ///@{
  /**
   * Box-filter frames much finer than the panorama before sampling them (default on); see
   * hv::lighting::DualFisheyeStitcherOptions::PrefilterLargeInput.
   */
  vtkSetMacro(PrefilterLargeInput, bool);
  vtkGetMacro(PrefilterLargeInput, bool);
  vtkBooleanMacro(PrefilterLargeInput, bool);
  ///@}

  ///@{
  /**
   * Reduce display-referred frames by this power of two (box filter, cv::resize INTER_AREA in
   * 2x2 steps) before linearising them; default 1 (no reduction). For 16-bit frames, or 8-bit
   * ones with InterpolateEncodedFrames off, this is the fast path for large frames
   * (linearising a whole 1920x960 frame takes about 4 ms on one core, halving it first 0.4 ms).
   * Averaging encoded values underestimates radiance where bright and dark pixels mix (the
   * edges of lights), and a reduced frame is blurrier.
   */
  vtkSetClampMacro(InputReductionFactor, int, 1, 64);
  vtkGetMacro(InputReductionFactor, int);
  ///@}

  ///@{
  /**
   * 8-bit display-referred frames are sampled in their codes and only the samples are
   * linearised (hv::lighting::DualFisheyeStitcher::stitchEncoded): about 1.2 ms instead of
   * 5-7 ms for a 1920x960 frame on one core, at a small cost in accuracy where neighbouring
   * pixels differ strongly (default on). Off linearises the whole frame first.
   */
  vtkSetMacro(InterpolateEncodedFrames, bool);
  vtkGetMacro(InterpolateEncodedFrames, bool);
  vtkBooleanMacro(InterpolateEncodedFrames, bool);
  ///@}

  ///@{
  /**
   * Output the point array "ClippedFraction" for display-referred frames (default off: it
   * costs about 1.5 ms per 1920x960 frame on one core, as much as the stitch itself).
   */
  vtkSetMacro(ComputeClippedFraction, bool);
  vtkGetMacro(ComputeClippedFraction, bool);
  vtkBooleanMacro(ComputeClippedFraction, bool);
  ///@}

  ///@{
  /**
   * Fraction of full scale at which a display-referred channel counts as clipped for
   * "ClippedFraction" (default 250/255: video compression spreads clipped highlights over
   * the top few codes).
   */
  vtkSetClampMacro(ClippingThreshold, double, 0.0, 1.0);
  vtkGetMacro(ClippingThreshold, double);
  ///@}

  /**
   * Back lens gain relative to the front lens (R, G, B) that automatic matching divided out
   * in the last frame; 1 when matching is off.
   */
  vtkGetVector3Macro(BackToFrontGain, double);

  /**
   * How many times the remap tables were built (for tests and profiling).
   */
  vtkGetMacro(NumberOfTableBuilds, int);

protected:
  vtkDualFisheyeToEquirectangular();
  ~vtkDualFisheyeToEquirectangular() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  char* CalibrationFileName = nullptr;
  char* Preset = nullptr;
  int OutputDimensions[2] = { 512, 256 };
  double BlendBandDegrees = -1.0;
  int AutomaticGainMatching = -1;
  bool PrefilterLargeInput = true;
  int InputReductionFactor = 1;
  bool InterpolateEncodedFrames = true;
  bool ComputeClippedFraction = false;
  double ClippingThreshold = 250.0 / 255.0;
  double BackToFrontGain[3] = { 1.0, 1.0, 1.0 };
  int NumberOfTableBuilds = 0;

private:
  vtkDualFisheyeToEquirectangular(const vtkDualFisheyeToEquirectangular&) = delete;
  void operator=(const vtkDualFisheyeToEquirectangular&) = delete;

  struct vtkInternals;
  std::unique_ptr<vtkInternals> Internals;
};

#endif
