// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Bad input gives a clear error that says what to do, and no crash: eyes of different sizes,
// a missing auxiliary buffer, a missing matrix, NaN radiance, an illumination input without
// T, an empty image. After the errors the filter still denoises good frames.
#include "PathTracingTestScene.h"
#include "vtkStereoSpatioTemporalDenoiser.h"

#include "vtkDoubleArray.h"
#include "vtkExecutive.h"
#include "vtkFieldData.h"
#include "vtkTestErrorObserver.h"

#include <iostream>
#include <limits>

namespace
{
int failures = 0;

// Updates the filter and checks that an error containing `expected` was reported, by the
// filter or its executive.
void ExpectError(vtkStereoSpatioTemporalDenoiser* denoiser, const std::string& expected)
{
  vtkNew<vtkTest::ErrorObserver> observer;
  vtkNew<vtkTest::ErrorObserver> executiveObserver;
  const unsigned long tag = denoiser->AddObserver(vtkCommand::ErrorEvent, observer);
  const unsigned long executiveTag =
    denoiser->GetExecutive()->AddObserver(vtkCommand::ErrorEvent, executiveObserver);
  denoiser->Modified();
  denoiser->Update();
  denoiser->RemoveObserver(tag);
  denoiser->GetExecutive()->RemoveObserver(executiveTag);
  const std::string message = observer->GetErrorMessage();
  if (!observer->GetError() || message.find(expected) == std::string::npos)
  {
    std::cerr << "FAILED: expected an error containing '" << expected << "', got '" << message
              << "'\n";
    ++failures;
  }
}

vtkSmartPointer<vtkImageData> Copy(vtkImageData* image)
{
  auto copy = vtkSmartPointer<vtkImageData>::New();
  copy->DeepCopy(image);
  return copy;
}
}

int TestStereoSpatioTemporalDenoiserBadInput(int, char*[])
{
  pathtracingtest::OffscreenScene scene;
  scene.Mapper->ProgressiveAccumulationOff();
  scene.RenderStereo(32);
  auto left = Copy(scene.Mapper->GetEyeOutput(0));
  auto right = Copy(scene.Mapper->GetEyeOutput(1));
  vtkNew<vtkStereoSpatioTemporalDenoiser> denoiser;

  // Eyes of different sizes.
  scene.Mapper->RenderStereoFrame(scene.Volume, scene.View[0], scene.Projection[0],
    scene.View[1], scene.Projection[1], 24, 24);
  auto small = Copy(scene.Mapper->GetEyeOutput(1));
  denoiser->SetInputData(0, left);
  denoiser->SetInputData(1, small);
  ExpectError(denoiser, "differ in size");

  // A missing auxiliary buffer.
  auto noAlbedo = Copy(right);
  noAlbedo->GetPointData()->RemoveArray("Albedo");
  denoiser->SetInputData(1, noAlbedo);
  ExpectError(denoiser, "no \"Albedo\" point array");

  // A radiance array of the wrong layout.
  auto rgbOnly = Copy(right);
  vtkNew<vtkFloatArray> rgb;
  rgb->SetName("Radiance");
  rgb->SetNumberOfComponents(3);
  rgb->SetNumberOfTuples(rgbOnly->GetNumberOfPoints());
  rgb->Fill(0.0);
  rgbOnly->GetPointData()->AddArray(rgb);
  denoiser->SetInputData(1, rgbOnly);
  ExpectError(denoiser, "must be float with 4 component(s)");

  // An optional buffer of the wrong type: the first scatter scalars as doubles.
  auto doubleScalars = Copy(right);
  vtkNew<vtkDoubleArray> scalars;
  scalars->SetName("FirstScatterScalar");
  scalars->SetNumberOfTuples(doubleScalars->GetNumberOfPoints());
  scalars->Fill(0.5);
  doubleScalars->GetPointData()->AddArray(scalars);
  denoiser->SetInputData(1, doubleScalars);
  ExpectError(denoiser, "\"FirstScatterScalar\" array must be float with 1 component(s)");

  // The previous light's radiance with four components, and with an infinity.
  auto rgbaPreviousLight = Copy(right);
  vtkNew<vtkFloatArray> rgba;
  rgba->SetName("PreviousLightingRadiance");
  rgba->SetNumberOfComponents(4);
  rgba->SetNumberOfTuples(rgbaPreviousLight->GetNumberOfPoints());
  rgba->Fill(0.0);
  rgbaPreviousLight->GetPointData()->AddArray(rgba);
  denoiser->SetInputData(1, rgbaPreviousLight);
  ExpectError(denoiser, "\"PreviousLightingRadiance\" array must be float with 3 component(s)");
  auto poisonedPreviousLight = Copy(right);
  vtkNew<vtkFloatArray> previousLight;
  previousLight->SetName("PreviousLightingRadiance");
  previousLight->SetNumberOfComponents(3);
  previousLight->SetNumberOfTuples(poisonedPreviousLight->GetNumberOfPoints());
  previousLight->Fill(0.1);
  previousLight->SetComponent(7, 2, std::numeric_limits<float>::infinity());
  poisonedPreviousLight->GetPointData()->AddArray(previousLight);
  denoiser->SetInputData(1, poisonedPreviousLight);
  // Read, and so checked, only where T says the light changed.
  denoiser->SetIlluminationDifference(0.5);
  ExpectError(denoiser, "previous lighting's radiance contains 1 NaN or infinite values");
  denoiser->SetIlluminationDifference(0.0);

  // A missing matrix.
  auto noMatrix = Copy(right);
  noMatrix->GetFieldData()->RemoveArray("ProjectionMatrix");
  denoiser->SetInputData(1, noMatrix);
  ExpectError(denoiser, "\"ProjectionMatrix\"");

  // NaN radiance.
  auto poisoned = Copy(right);
  vtkFloatArray::SafeDownCast(poisoned->GetPointData()->GetArray("Radiance"))
    ->SetComponent(100, 1, std::numeric_limits<float>::quiet_NaN());
  denoiser->SetInputData(1, poisoned);
  ExpectError(denoiser, "1 NaN or infinite values");

  // An illumination input without T.
  denoiser->SetInputData(1, right);
  vtkNew<vtkImageData> notALight;
  denoiser->SetInputData(2, notALight);
  ExpectError(denoiser, "no \"IlluminationDifference\" field array");
  denoiser->SetInputData(2, nullptr);

  // An empty image.
  vtkNew<vtkImageData> empty;
  denoiser->SetInputData(1, empty);
  ExpectError(denoiser, "non-empty 2D image");

  // Good frames still work after all that.
  denoiser->SetInputData(0, left);
  denoiser->SetInputData(1, right);
  denoiser->Update();
  vtkDataArray* radiance = denoiser->GetEyeOutput(1)->GetPointData()->GetArray("Radiance");
  if (!radiance || radiance->GetNumberOfTuples() != 32 * 32)
  {
    std::cerr << "FAILED: no denoised right eye after the errors\n";
    ++failures;
  }
  return failures == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
