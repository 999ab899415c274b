// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Cutting tools: a clipping plane removes the half-space its normal points away from, and
// VTK's cropping regions remove the excluded blocks; everything else is unchanged.
#include "PathTracingTestScene.h"

#include "vtkFloatArray.h"
#include "vtkPlane.h"
#include "vtkPlaneCollection.h"

#include <iostream>

namespace
{
// Coverage (alpha) of the left and right halves of the image, away from the centre line.
void HalfCoverage(vtkPathTracedVolumeMapper* mapper, int size, double& left, double& right)
{
  auto* radiance =
    vtkFloatArray::SafeDownCast(mapper->GetEyeOutput(0)->GetPointData()->GetArray("Radiance"));
  left = right = 0.0;
  for (int y = 0; y < size; ++y)
  {
    for (int x = 0; x < size; ++x)
    {
      const double alpha = radiance->GetComponent(y * size + x, 3);
      if (x < size / 2 - 2)
      {
        left += alpha;
      }
      else if (x > size / 2 + 1)
      {
        right += alpha;
      }
    }
  }
}

// The camera looks down -Z at the origin, so image x follows world x.
void FrontView(vtkMatrix4x4* view, vtkMatrix4x4* projection)
{
  vtkNew<vtkCamera> camera;
  camera->SetPosition(0, 0, 60);
  camera->SetFocalPoint(0, 0, 0);
  camera->SetViewUp(0, 1, 0);
  camera->SetViewAngle(30);
  camera->SetClippingRange(20, 100);
  view->DeepCopy(camera->GetModelViewTransformMatrix());
  projection->DeepCopy(camera->GetProjectionTransformMatrix(1.0, -1, 1));
}
}

int TestPathTracedClipping(int, char*[])
{
  const int size = 64;
  int failures = 0;
  pathtracingtest::OffscreenScene scene;
  // A dense sphere, so coverage is clear-cut.
  scene.Property->SetScalarOpacityUnitDistance(0.02);
  scene.Mapper->SetSamplesPerPixel(4);
  vtkNew<vtkMatrix4x4> view, projection;
  FrontView(view, projection);
  auto render = [&]() { scene.Mapper->RenderEye(scene.Volume, 0, view, projection, size, size); };

  double left, right;
  render();
  HalfCoverage(scene.Mapper, size, left, right);
  std::cout << "no cut: coverage left " << left << " right " << right << "\n";
  const double full = 0.5 * (left + right);
  if (full < 200 || std::abs(left - right) > 0.1 * full)
  {
    std::cerr << "FAILED: the uncut sphere should cover both halves equally\n";
    ++failures;
  }

  vtkNew<vtkPlane> plane;
  plane->SetOrigin(0, 0, 0);
  plane->SetNormal(1, 0, 0); // keeps x >= 0
  scene.Mapper->AddClippingPlane(plane);
  render();
  HalfCoverage(scene.Mapper, size, left, right);
  std::cout << "clip x>=0: coverage left " << left << " right " << right << "\n";
  if (left > 0.0 || std::abs(right - full) > 0.1 * full)
  {
    std::cerr << "FAILED: the clipping plane should remove exactly the left half\n";
    ++failures;
  }
  plane->SetNormal(-1, 0, 0); // a modified plane takes effect on the next frame
  render();
  HalfCoverage(scene.Mapper, size, left, right);
  std::cout << "clip x<=0: coverage left " << left << " right " << right << "\n";
  if (right > 0.0 || std::abs(left - full) > 0.1 * full)
  {
    std::cerr << "FAILED: the flipped plane should remove exactly the right half\n";
    ++failures;
  }
  scene.Mapper->RemoveAllClippingPlanes();

  // Cropping: keep only the regions with x in the upper third (data coordinates, x > 0).
  double bounds[6];
  vtkImageData::SafeDownCast(scene.Mapper->GetInput())->GetBounds(bounds);
  scene.Mapper->CroppingOn();
  scene.Mapper->SetCroppingRegionPlanes(0.0, bounds[1], bounds[2], bounds[3], bounds[4], bounds[5]);
  scene.Mapper->SetCroppingRegionFlags(VTK_CROP_SUBVOLUME);
  render();
  HalfCoverage(scene.Mapper, size, left, right);
  std::cout << "crop subvolume x>=0: coverage left " << left << " right " << right << "\n";
  if (left > 0.0 || std::abs(right - full) > 0.1 * full)
  {
    std::cerr << "FAILED: the cropping subvolume should keep only x >= 0\n";
    ++failures;
  }
  // Inverted: every region except the central column (x < 0 regions only kept).
  int flags = 0;
  for (int z = 0; z < 3; ++z)
  {
    for (int y = 0; y < 3; ++y)
    {
      flags |= 1 << (0 + 3 * y + 9 * z);
    }
  }
  scene.Mapper->SetCroppingRegionFlags(flags);
  render();
  HalfCoverage(scene.Mapper, size, left, right);
  std::cout << "crop regions x<0: coverage left " << left << " right " << right << "\n";
  if (right > 0.0 || std::abs(left - full) > 0.1 * full)
  {
    std::cerr << "FAILED: general cropping flags should keep only the x < 0 regions\n";
    ++failures;
  }
  return failures == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
