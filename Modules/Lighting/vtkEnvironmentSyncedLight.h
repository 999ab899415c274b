// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
/**
 * @class   vtkEnvironmentSyncedLight
 * @brief   Live HDR radiance map of the real room, aligned with the world and centred on the
 *          volume, from the panorama of a head-mounted 360-degree camera.
 *
 * Input: a camera-frame equirectangular panorama (width = 2 x height), for example the output
 * of vtkDualFisheyeToEquirectangular or of vtkPanoramaVideoSource on an equirectangular
 * camera. Unsigned char and unsigned short panoramas are display-referred and are linearised
 * with the camera response; a float panorama is taken as linear, and as HDR when its field
 * data "SourceEncoding" (or "Encoding") says "SceneLinear" or InputDynamicRange forces it.
 *
 * Per frame (Section 3.1 of the method):
 * 1. spatial calibration: the headset pose (world from headset) and the fixed camera mount
 *    (headset from camera) rotate the panorama into the world, and a proxy room (a sphere
 *    around the camera, or a box fixed in the world) re-centres it on VolumeCenter;
 * 2. LDR to HDR: light sources are detected in the clipped panorama and their radiance is
 *    estimated (HDR input bypasses this), giving the radiance map Q;
 * 3. the illumination difference T in [0, 1) between this frame's Q and the previous one,
 *    from patch-wise log-SSIM;
 * 4. optional temporal smoothing of Q while T is small.
 *
 * Output port 0: Q as float RGB "Radiance" in world orientation (EnvironmentToWorldMatrix of
 * vtkPathTracedVolumeMapper stays identity), VTK row order (j = 0 the nadir); field data
 * "IlluminationDifference" (T), "PatchSimilarity" (N x N, row-major from the zenith),
 * "FrameIndex" (passed from the input when present, else the count of distinct input frames
 * this filter has seen, so that vtkStereoSpatioTemporalDenoiser can tell a new camera frame
 * from a re-execution with the same one). Connect it with
 * vtkPathTracedVolumeMapper::SetEnvironmentMapConnection(): the mapper's accumulation
 * restarts when Q changes.
 * Output port 1: the detected lights as vtkPolyData, one vertex per light at VolumeCenter +
 * direction, with point arrays "Direction", "SolidAngle" (sr), "Color" (chromaticity,
 * luminance 1), "Intensity" (mean radiance) and "Radiance" (RGB).
 *
 * T is relative to the last distinct input frame: re-executing for a new pose or a changed
 * setting with the same input frame does not count as a lighting change.
 */

#ifndef vtkEnvironmentSyncedLight_h
#define vtkEnvironmentSyncedLight_h

#include "holoLightingModule.h" // For export macro
#include "vtkImageAlgorithm.h"

#include <memory> // For std::unique_ptr

class vtkMatrix4x4;
class vtkPolyData;

class HOLOLIGHTING_EXPORT vtkEnvironmentSyncedLight : public vtkImageAlgorithm
{
public:
  static vtkEnvironmentSyncedLight* New();
  vtkTypeMacro(vtkEnvironmentSyncedLight, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /**
   * Headset pose for the current frame: world from headset, rigid (default identity). The
   * matrix is copied.
   */
  void SetHeadsetPose(vtkMatrix4x4* worldFromHeadset);
  vtkMatrix4x4* GetHeadsetPose() { return this->HeadsetPose; }
  ///@}

  ///@{
  /**
   * Fixed transform from the 360-degree camera's frame (+Y up, front lens along -Z) to the
   * headset's frame: how the camera is mounted (default identity). The matrix is copied.
   */
  void SetCameraMountTransform(vtkMatrix4x4* headsetFromCamera);
  vtkMatrix4x4* GetCameraMountTransform() { return this->CameraMountTransform; }
  ///@}

  ///@{
  /**
   * Centre of the volume in world coordinates: the panorama is re-projected to be seen from
   * here (default origin).
   */
  vtkSetVector3Macro(VolumeCenter, double);
  vtkGetVector3Macro(VolumeCenter, double);
  ///@}

  enum ProxyGeometryType
  {
    CAMERA_CENTERED_SPHERE = 0,
    WORLD_BOX = 1
  };

  ///@{
  /**
   * Room geometry assumed behind the panorama: a sphere of ProxyRadius around the camera
   * (default, Gardner et al. 2017) or the world-fixed box ProxyBox (xmin, xmax, ymin, ymax,
   * zmin, zmax). Both in world units (metres for a headset; default radius 2.5).
   */
  vtkSetClampMacro(ProxyGeometry, int, CAMERA_CENTERED_SPHERE, WORLD_BOX);
  vtkGetMacro(ProxyGeometry, int);
  void SetProxyGeometryToCameraCenteredSphere() { this->SetProxyGeometry(CAMERA_CENTERED_SPHERE); }
  void SetProxyGeometryToWorldBox() { this->SetProxyGeometry(WORLD_BOX); }
  vtkSetMacro(ProxyRadius, double);
  vtkGetMacro(ProxyRadius, double);
  vtkSetVector6Macro(ProxyBox, double);
  vtkGetVector6Macro(ProxyBox, double);
  ///@}

  ///@{
  /**
   * Height of the output radiance map (width = 2 x height); 0 keeps the input's size
   * (default 256, the paper's 512 x 256).
   */
  vtkSetClampMacro(OutputHeight, int, 0, 8192);
  vtkGetMacro(OutputHeight, int);
  ///@}

  enum DynamicRangeType
  {
    AUTOMATIC_DYNAMIC_RANGE = 0,
    LOW_DYNAMIC_RANGE = 1,
    HIGH_DYNAMIC_RANGE = 2
  };

  ///@{
  /**
   * Whether the input is a clipped LDR panorama (light sources are estimated) or HDR
   * (used as it is). Automatic (default) decides from the scalar type and field data.
   */
  vtkSetClampMacro(InputDynamicRange, int, AUTOMATIC_DYNAMIC_RANGE, HIGH_DYNAMIC_RANGE);
  vtkGetMacro(InputDynamicRange, int);
  ///@}

  enum RadianceRecoveryType
  {
    LIGHT_SOURCE_ESTIMATION = 0,
    LDR_AS_HDR = 1,
    LANDIS_EXPANSION = 2
  };

  ///@{
  /**
   * How Q is recovered from an LDR panorama: the light-source detection and intensity
   * estimation (default), or the evaluation's baselines: the LDR values used as radiance,
   * and Landis' classical expansion operator.
   */
  vtkSetClampMacro(RadianceRecovery, int, LIGHT_SOURCE_ESTIMATION, LANDIS_EXPANSION);
  vtkGetMacro(RadianceRecovery, int);
  ///@}

  ///@{
  /**
   * Camera exposure relative to the reference exposure: linear values are divided by it so
   * that Q keeps its scale when the camera's auto-exposure changes (default 1).
   */
  vtkSetMacro(Exposure, double);
  vtkGetMacro(Exposure, double);
  ///@}

  ///@{
  /**
   * A camera response recovered from bracketed shots (JSON written by the CameraResponse
   * kernel); empty (default) uses the sRGB transfer function.
   */
  vtkSetFilePathMacro(CameraResponseFileName);
  vtkGetFilePathMacro(CameraResponseFileName);
  ///@}

  ///@{
  /**
   * N: Q is cut into N x N patches for the illumination difference (default 8).
   */
  vtkSetClampMacro(PatchGridSize, int, 1, 64);
  vtkGetMacro(PatchGridSize, int);
  ///@}

  enum IlluminationDifferenceModeType
  {
    LEAST_SIMILAR_PATCH = 0,
    MOST_SIMILAR_PATCH = 1
  };

  ///@{
  /**
   * T = 1 - the similarity of the least similar patch (default: a strong change in any patch
   * means the lighting changed, as the paper's text says), or of the most similar patch (the
   * paper's Eq. 1 as printed).
   */
  vtkSetClampMacro(IlluminationDifferenceMode, int, LEAST_SIMILAR_PATCH, MOST_SIMILAR_PATCH);
  vtkGetMacro(IlluminationDifferenceMode, int);
  void SetIlluminationDifferenceModeToLeastSimilarPatch()
  {
    this->SetIlluminationDifferenceMode(LEAST_SIMILAR_PATCH);
  }
  void SetIlluminationDifferenceModeToMostSimilarPatch()
  {
    this->SetIlluminationDifferenceMode(MOST_SIMILAR_PATCH);
  }
  ///@}

  ///@{
  /**
   * Smooth Q over frames while T is small, so that sensor noise does not make the lighting
   * flicker (default on). Below TemporalSmoothingLowT the new frame gets weight
   * TemporalSmoothingWeight; above TemporalSmoothingHighT the history is dropped.
   */
  vtkSetMacro(TemporalSmoothing, bool);
  vtkGetMacro(TemporalSmoothing, bool);
  vtkBooleanMacro(TemporalSmoothing, bool);
  vtkSetClampMacro(TemporalSmoothingWeight, double, 0.0, 1.0);
  vtkGetMacro(TemporalSmoothingWeight, double);
  vtkSetClampMacro(TemporalSmoothingLowT, double, 0.0, 1.0);
  vtkGetMacro(TemporalSmoothingLowT, double);
  vtkSetClampMacro(TemporalSmoothingHighT, double, 0.0, 1.0);
  vtkGetMacro(TemporalSmoothingHighT, double);
  ///@}

  /**
   * The illumination difference T of the last frame, in [0, 1).
   */
  double GetIlluminationDifference() const { return this->IlluminationDifference; }

  /**
   * Forgets the previous frame (T and smoothing start afresh with the next frame).
   */
  void ResetHistory();

  /**
   * The detected lights of the last frame (output port 1).
   */
  vtkPolyData* GetDetectedLights();

  /**
   * Milliseconds spent on the last frame by the kernels (alignment, radiance recovery,
   * illumination difference, smoothing), without VTK's copies.
   */
  double GetLastFrameMilliseconds() const { return this->LastFrameMilliseconds; }

protected:
  vtkEnvironmentSyncedLight();
  ~vtkEnvironmentSyncedLight() override;

  int FillOutputPortInformation(int port, vtkInformation* info) override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  vtkMatrix4x4* HeadsetPose;
  vtkMatrix4x4* CameraMountTransform;
  double VolumeCenter[3] = { 0.0, 0.0, 0.0 };
  int ProxyGeometry = CAMERA_CENTERED_SPHERE;
  double ProxyRadius = 2.5;
  double ProxyBox[6] = { -2.5, 2.5, -1.5, 1.5, -2.5, 2.5 };
  int OutputHeight = 256;
  int InputDynamicRange = AUTOMATIC_DYNAMIC_RANGE;
  int RadianceRecovery = LIGHT_SOURCE_ESTIMATION;
  double Exposure = 1.0;
  char* CameraResponseFileName = nullptr;
  int PatchGridSize = 8;
  int IlluminationDifferenceMode = LEAST_SIMILAR_PATCH;
  bool TemporalSmoothing = true;
  double TemporalSmoothingWeight = 0.25;
  double TemporalSmoothingLowT = 0.05;
  double TemporalSmoothingHighT = 0.3;

  double IlluminationDifference = 0.0;
  double LastFrameMilliseconds = 0.0;

private:
  vtkEnvironmentSyncedLight(const vtkEnvironmentSyncedLight&) = delete;
  void operator=(const vtkEnvironmentSyncedLight&) = delete;

  struct Internals;
  std::unique_ptr<Internals> Internal;
};

#endif
