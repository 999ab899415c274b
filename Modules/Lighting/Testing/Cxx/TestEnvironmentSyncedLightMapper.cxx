// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Hook-up: vtkEnvironmentSyncedLight's radiance map lights vtkPathTracedVolumeMapper through a
// pipeline connection. Accumulation continues while the room stays the same and restarts
// when a lamp switches off, and the rendering then gets darker.
#include "PathTracingTestScene.h"

#include "vtkEnvironmentSyncedLight.h"

#include "LightingTestUtilities.h"

#include "vtkFieldData.h"
#include "vtkTrivialProducer.h"
#include "vtkUnsignedCharArray.h"

#include <opencv2/core.hpp>

#include <iostream>

namespace
{
// An 8-bit sRGB room: grey walls (linear 0.15) and, if lit, a ceiling lamp of 25 degrees radius
// straight above at 50 x the clip level, filmed through the lens's PSF.
vtkSmartPointer<vtkImageData> MakeRoom(bool lampOn)
{
  const int width = 256, height = 128;
  cv::Mat linear(height, width, CV_32FC3, cv::Scalar::all(0.15));
  if (lampOn)
  {
    for (int row = 0; row < height; ++row)
    {
      if ((row + 0.5) / height * 180.0 < 25.0)
      {
        linear.row(row).setTo(cv::Scalar::all(50.0));
      }
    }
  }
  return lightingtest::FilmLdrPanorama(linear);
}

double MeanRadiance(vtkPathTracedVolumeMapper* mapper)
{
  auto* array =
    vtkFloatArray::SafeDownCast(mapper->GetEyeOutput(0)->GetPointData()->GetArray("Radiance"));
  double sum = 0.0;
  for (vtkIdType i = 0; i < array->GetNumberOfTuples(); ++i)
  {
    sum += array->GetComponent(i, 1);
  }
  return sum / array->GetNumberOfTuples();
}
}

int TestEnvironmentSyncedLightMapper(int, char*[])
{
  int failures = 0;
  auto expect = [&](bool condition, const char* what)
  {
    if (!condition)
    {
      std::cerr << "FAILED: " << what << "\n";
      ++failures;
    }
  };

  vtkNew<vtkTrivialProducer> camera;
  camera->SetOutput(MakeRoom(true));
  vtkNew<vtkEnvironmentSyncedLight> synced;
  synced->SetInputConnection(camera->GetOutputPort());
  synced->SetOutputHeight(64);

  pathtracingtest::OffscreenScene scene;
  scene.Mapper->SetEnvironmentMapConnection(synced->GetOutputPort());
  scene.Mapper->SetSamplesPerPixel(4);
  scene.Mapper->SetSeed(3);
  scene.Mapper->SetEnvironmentVisible(false);

  expect(scene.RenderStereo(32) == 1, "first frame renders");
  const double lit = MeanRadiance(scene.Mapper);
  expect(scene.RenderStereo(32) == 1, "second frame renders");
  expect(scene.Mapper->GetAccumulatedFrames(0) == 2, "accumulates while the room is unchanged");

  camera->SetOutput(MakeRoom(false));
  expect(scene.RenderStereo(32) == 1, "frame after the lamp switched off renders");
  const double dark = MeanRadiance(scene.Mapper);
  std::cout << "mean radiance lamp on " << lit << ", off " << dark << ", T "
            << synced->GetIlluminationDifference() << "\n";
  expect(
    scene.Mapper->GetAccumulatedFrames(0) == 1, "accumulation restarts when the light changes");
  expect(synced->GetIlluminationDifference() > 0.5, "the lamp switching off gives a large T");
  // The lamp (recovered HDR, far above the walls' 0.13) dominates the lighting.
  expect(dark < 0.5 * lit, "the volume gets darker when the lamp goes off");
  return failures == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
