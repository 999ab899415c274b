// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Scene set-up shared by the holovolume application and the benchmark, so both render the
// same views of the same data: the transfer-function preset for a T1 head MRI, the
// environment orientation for RAS volumes, and the headset-like stereo eyes.
#ifndef vtkHoloVolumeScene_h
#define vtkHoloVolumeScene_h

#include "vtkCamera.h"
#include "vtkColorTransferFunction.h"
#include "vtkImageData.h"
#include "vtkMath.h"
#include "vtkMatrix4x4.h"
#include "vtkNIFTIImageReader.h"
#include "vtkNew.h"
#include "vtkPiecewiseFunction.h"
#include "vtkSmartPointer.h"
#include "vtkVolumeProperty.h"
#include "vtkXMLImageDataReader.h"

#include "HoloVolumeOptions.h"

#include <string>
#include <sys/stat.h>

namespace holovolume
{
// Default inputs, from Debian packages (mricron-data, blender-data).
inline const char* DefaultVolume()
{
  return "/usr/share/mricron/templates/ch2.nii.gz";
}
inline const char* DefaultEnvironment()
{
  return "/usr/share/blender/datafiles/studiolights/world/courtyard.exr";
}

inline bool FileExists(const std::string& path)
{
  struct stat info;
  return stat(path.c_str(), &info) == 0;
}

// Reads a VTK XML image (.vti) or a NIfTI volume (.nii, .nii.gz); nullptr when nothing was read.
inline vtkSmartPointer<vtkImageData> ReadVolume(const std::string& path)
{
  vtkSmartPointer<vtkImageData> volume;
  if (path.size() >= 4 && path.compare(path.size() - 4, 4, ".vti") == 0)
  {
    vtkNew<vtkXMLImageDataReader> reader;
    reader->SetFileName(path.c_str());
    reader->Update();
    volume = reader->GetOutput();
  }
  else
  {
    vtkNew<vtkNIFTIImageReader> reader;
    reader->SetFileName(path.c_str());
    reader->Update();
    volume = reader->GetOutput();
  }
  return volume && volume->GetNumberOfPoints() > 0 ? volume : nullptr;
}

// The head presets' scalar opacity, scalars on an 8-bit scale (scaled to scalarMaximum): none up
// to `transparentUpTo`, rising to `rampOpacity` at `rampEnd` and to `maximumOpacity` at the top.
inline void SetThresholdOpacity(vtkVolumeProperty* property, double scalarMaximum,
  double transparentUpTo, double rampEnd, double rampOpacity, double maximumOpacity)
{
  const double s = scalarMaximum / 255.0;
  vtkNew<vtkPiecewiseFunction> opacity;
  opacity->AddPoint(0.0, 0.0);
  opacity->AddPoint(transparentUpTo * s, 0.0);
  opacity->AddPoint(rampEnd * s, rampOpacity);
  opacity->AddPoint(255.0 * s, maximumOpacity);
  property->SetScalarOpacity(opacity);
}

// Transfer function for an 8-bit T1-weighted head MRI such as ch2 (MNI space, 1 mm):
// background below ~25, scalp and skin from ~35 on, brain tissue 70-130. Opacity per 1 mm.
inline void ApplyHeadMRIPreset(vtkVolumeProperty* property, double scalarMaximum = 255.0)
{
  const double s = scalarMaximum / 255.0;
  SetThresholdOpacity(property, scalarMaximum, 28.0, 40.0, 0.9, 0.98);
  vtkNew<vtkColorTransferFunction> color;
  color->AddRGBPoint(0.0, 0.80, 0.55, 0.45);
  color->AddRGBPoint(45.0 * s, 0.85, 0.62, 0.52);
  color->AddRGBPoint(90.0 * s, 0.92, 0.78, 0.70);
  color->AddRGBPoint(140.0 * s, 0.97, 0.93, 0.88);
  color->AddRGBPoint(255.0 * s, 1.0, 1.0, 1.0);
  property->SetColor(color);
  property->SetScalarOpacityUnitDistance(1.0);
  property->SetInterpolationTypeToLinear();
  property->ShadeOn();
  property->SetAmbient(0.15);
  property->SetDiffuse(0.8);
  property->SetSpecular(0.2);
  property->SetSpecularPower(20.0);
}

// The head MRI preset made translucent: the same threshold and colours, an opacity of 0.08 at
// the skin rising to 0.3, so that what lies under the skin shows through it.
inline void ApplyTranslucentHeadPreset(vtkVolumeProperty* property, double scalarMaximum = 255.0)
{
  ApplyHeadMRIPreset(property, scalarMaximum);
  SetThresholdOpacity(property, scalarMaximum, 28.0, 40.0, 0.08, 0.3);
}

// The tissue inside the skin: the head MRI preset with its threshold raised to 75-95 (T1: brain
// 70-130, skin and fat from ~35).
inline void ApplyInnerTissuePreset(vtkVolumeProperty* property, double scalarMaximum = 255.0)
{
  ApplyHeadMRIPreset(property, scalarMaximum);
  SetThresholdOpacity(property, scalarMaximum, 75.0, 95.0, 0.9, 0.98);
}

// Maps the environment map's frame (+Y zenith) to a RAS world (+Z superior), with the
// panorama's centre in front of the face (+Y anterior), turned by yawDegrees about +Z.
inline void EnvironmentToRASWorld(vtkMatrix4x4* matrix, double yawDegrees)
{
  const double yaw = vtkMath::RadiansFromDegrees(yawDegrees);
  const double c = std::cos(yaw), s = std::sin(yaw);
  // Columns: images of the map's X, Y, Z axes. Map X -> world X, map Y -> world Z,
  // map Z -> world -Y, then the yaw about world Z.
  const double base[3][3] = { { 1, 0, 0 }, { 0, 0, -1 }, { 0, 1, 0 } };
  matrix->Identity();
  for (int row = 0; row < 3; ++row)
  {
    for (int column = 0; column < 3; ++column)
    {
      const double x = base[0][column], y = base[1][column];
      const double rotated[3] = { c * x - s * y, s * x + c * y, base[2][column] };
      matrix->SetElement(row, column, rotated[row]);
    }
  }
}

// A camera looking at the volume's centre from the front-left-above, head up (+Z), far
// enough that the whole volume fits a view angle of 30 degrees.
inline void FrameHead(vtkCamera* camera, vtkImageData* volume, double azimuthDegrees = 35.0)
{
  double bounds[6];
  volume->GetBounds(bounds);
  const double center[3] = { 0.5 * (bounds[0] + bounds[1]), 0.5 * (bounds[2] + bounds[3]),
    0.5 * (bounds[4] + bounds[5]) };
  const double radius = 0.5 *
    std::sqrt((bounds[1] - bounds[0]) * (bounds[1] - bounds[0]) +
      (bounds[3] - bounds[2]) * (bounds[3] - bounds[2]) +
      (bounds[5] - bounds[4]) * (bounds[5] - bounds[4]));
  const double distance = radius / std::sin(vtkMath::RadiansFromDegrees(15.0));
  const double azimuth = vtkMath::RadiansFromDegrees(azimuthDegrees);
  const double elevation = vtkMath::RadiansFromDegrees(12.0);
  camera->SetFocalPoint(center);
  camera->SetPosition(center[0] + distance * std::cos(elevation) * std::sin(azimuth),
    center[1] + distance * std::cos(elevation) * std::cos(azimuth),
    center[2] + distance * std::sin(elevation));
  camera->SetViewUp(0, 0, 1);
  camera->SetViewAngle(30.0);
  camera->SetClippingRange(
    distance - 1.5 * radius > 1.0 ? distance - 1.5 * radius : 1.0, distance + 1.5 * radius);
}

// One eye of a stereo pair around `camera`: shifted by half the interpupillary distance along
// the camera's right axis, parallel view direction, and an off-axis frustum converging on the
// focal plane (zero parallax there), the way a headset renders.
inline void StereoEyeCamera(
  vtkCamera* camera, double aspect, double interpupillaryDistance, int eye, vtkCamera* eyeCamera)
{
  eyeCamera->DeepCopy(camera);
  double right[3], direction[3];
  camera->GetDirectionOfProjection(direction);
  vtkMath::Cross(direction, camera->GetViewUp(), right);
  vtkMath::Normalize(right);
  const double offset = (eye == 0 ? -0.5 : 0.5) * interpupillaryDistance;
  double position[3], focal[3];
  camera->GetPosition(position);
  camera->GetFocalPoint(focal);
  for (int i = 0; i < 3; ++i)
  {
    position[i] += offset * right[i];
    focal[i] += offset * right[i];
  }
  eyeCamera->SetPosition(position);
  eyeCamera->SetFocalPoint(focal);
  const double halfHeight =
    std::tan(vtkMath::RadiansFromDegrees(camera->GetViewAngle()) / 2.0) * camera->GetDistance();
  eyeCamera->SetWindowCenter(-offset / (halfHeight * aspect), 0.0);
}

// The eye's view and projection matrices (OpenGL convention), as a headset would send them.
inline void StereoEyeMatrices(vtkCamera* camera, double aspect, double interpupillaryDistance,
  int eye, vtkMatrix4x4* view, vtkMatrix4x4* projection)
{
  vtkNew<vtkCamera> eyeCamera;
  StereoEyeCamera(camera, aspect, interpupillaryDistance, eye, eyeCamera);
  view->DeepCopy(eyeCamera->GetModelViewTransformMatrix());
  projection->DeepCopy(eyeCamera->GetProjectionTransformMatrix(aspect, -1, 1));
}
}

#endif
