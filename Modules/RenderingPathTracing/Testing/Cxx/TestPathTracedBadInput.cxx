// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Bad input gives a clear error or warning that says what to do, and no crash: no input,
// multi-component scalars, a 2D or empty extent, a zero-opacity transfer function, NaN or
// a wrong aspect ratio in the environment map, singular matrices, an invalid eye.
#include "PathTracingTestScene.h"

#include "vtkFloatArray.h"
#include "vtkTestErrorObserver.h"

#include <algorithm>
#include <iostream>
#include <limits>

namespace
{
int failures = 0;

// Runs `action` and checks that an error (or a warning) containing `expected` was reported.
template <typename Action>
void ExpectMessage(
  vtkPathTracedVolumeMapper* mapper, bool warning, const std::string& expected, Action action)
{
  vtkNew<vtkTest::ErrorObserver> observer;
  const unsigned long tag =
    mapper->AddObserver(warning ? vtkCommand::WarningEvent : vtkCommand::ErrorEvent, observer);
  action();
  mapper->RemoveObserver(tag);
  const bool reported = warning ? observer->GetWarning() : observer->GetError();
  const std::string message = warning ? observer->GetWarningMessage() : observer->GetErrorMessage();
  if (!reported || message.find(expected) == std::string::npos)
  {
    std::cerr << "FAILED: expected a " << (warning ? "warning" : "error") << " containing '"
              << expected << "', got '" << message << "'\n";
    ++failures;
  }
}
}

int TestPathTracedBadInput(int, char*[])
{
  const int size = 16;
  {
    pathtracingtest::OffscreenScene scene;
    scene.Mapper->RemoveAllInputConnections(0);
    ExpectMessage(scene.Mapper, false, "No input volume", [&] { scene.RenderStereo(size); });
  }
  {
    pathtracingtest::OffscreenScene scene;
    vtkNew<vtkImageData> vectors;
    vectors->SetDimensions(8, 8, 8);
    vectors->AllocateScalars(VTK_FLOAT, 3);
    scene.Mapper->SetInputData(vectors);
    ExpectMessage(
      scene.Mapper, false, "vtkImageExtractComponents", [&] { scene.RenderStereo(size); });
  }
  {
    pathtracingtest::OffscreenScene scene;
    vtkNew<vtkImageData> slice;
    slice->SetDimensions(8, 8, 1);
    slice->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
    scene.Mapper->SetInputData(slice);
    ExpectMessage(scene.Mapper, false, "at least 2 samples", [&] { scene.RenderStereo(size); });
    vtkNew<vtkImageData> empty;
    scene.Mapper->SetInputData(empty);
    ExpectMessage(scene.Mapper, false, "at least 2 samples", [&] { scene.RenderStereo(size); });
  }
  {
    pathtracingtest::OffscreenScene scene;
    vtkNew<vtkPiecewiseFunction> zero;
    zero->AddPoint(0, 0.0);
    zero->AddPoint(2000, 0.0);
    scene.Property->SetScalarOpacity(zero);
    ExpectMessage(scene.Mapper, true, "Add opacity points", [&] { scene.RenderStereo(size); });
    // Still renders: an empty, transparent image.
    auto* radiance = vtkFloatArray::SafeDownCast(
      scene.Mapper->GetEyeOutput(0)->GetPointData()->GetArray("Radiance"));
    if (!radiance || radiance->GetRange(3)[1] != 0.0)
    {
      std::cerr << "FAILED: a zero-opacity volume should render fully transparent\n";
      ++failures;
    }
  }
  {
    pathtracingtest::OffscreenScene scene;
    auto sky = pathtracingtest::MakeSky();
    vtkFloatArray::SafeDownCast(sky->GetPointData()->GetScalars())
      ->SetComponent(5, 1, std::numeric_limits<float>::quiet_NaN());
    scene.Mapper->SetEnvironmentMapData(sky);
    ExpectMessage(scene.Mapper, false, "NaN", [&] { scene.RenderStereo(size); });
    auto wide = vtkSmartPointer<vtkImageData>::New();
    wide->SetDimensions(30, 10, 1);
    wide->AllocateScalars(VTK_FLOAT, 3);
    wide->GetPointData()->GetScalars()->Fill(1.0);
    scene.Mapper->SetEnvironmentMapData(wide);
    ExpectMessage(scene.Mapper, false, "twice as wide", [&] { scene.RenderStereo(size); });
    auto gray = vtkSmartPointer<vtkImageData>::New();
    gray->SetDimensions(20, 10, 1);
    gray->AllocateScalars(VTK_FLOAT, 1);
    scene.Mapper->SetEnvironmentMapData(gray);
    ExpectMessage(scene.Mapper, false, "RGB", [&] { scene.RenderStereo(size); });
  }
  {
    // After a usable map, an unusable one: the frame is lit by the uniform environment, as the
    // message says, not by the map held from before.
    pathtracingtest::OffscreenScene scene;
    scene.RenderStereo(size);
    auto gray = vtkSmartPointer<vtkImageData>::New();
    gray->SetDimensions(20, 10, 1);
    gray->AllocateScalars(VTK_FLOAT, 1);
    scene.Mapper->SetEnvironmentMapData(gray);
    ExpectMessage(scene.Mapper, false, "RGB", [&] { scene.RenderStereo(size); });
    pathtracingtest::OffscreenScene uniform;
    uniform.Mapper->SetEnvironmentMapData(nullptr);
    uniform.Mapper->SetFrameIndex(scene.Mapper->GetFrameIndex() - 1);
    uniform.RenderStereo(size);
    auto* lit = vtkFloatArray::SafeDownCast(
      scene.Mapper->GetEyeOutput(0)->GetPointData()->GetArray("Radiance"));
    auto* expected = vtkFloatArray::SafeDownCast(
      uniform.Mapper->GetEyeOutput(0)->GetPointData()->GetArray("Radiance"));
    if (!std::equal(
          lit->GetPointer(0), lit->GetPointer(0) + 4 * size * size, expected->GetPointer(0)))
    {
      std::cerr << "FAILED: a frame under an unusable environment map is not lit by the uniform "
                   "environment\n";
      ++failures;
    }
  }
  {
    pathtracingtest::OffscreenScene scene;
    vtkNew<vtkMatrix4x4> zero;
    zero->Zero();
    ExpectMessage(scene.Mapper, false, "singular",
      [&]
      {
        scene.Mapper->RenderStereoFrame(
          scene.Volume, zero, zero, scene.View[1], scene.Projection[1], size, size);
      });
    ExpectMessage(scene.Mapper, false, "positive width",
      [&]
      {
        scene.Mapper->RenderStereoFrame(scene.Volume, scene.View[0], scene.Projection[0],
          scene.View[1], scene.Projection[1], 0, size);
      });
    ExpectMessage(scene.Mapper, false, "must be 0", [&] { scene.Mapper->GetEyeOutput(2); });
    ExpectMessage(scene.Mapper, false, "must be 0",
      [&] {
        scene.Mapper->RenderEye(scene.Volume, 3, scene.View[0], scene.Projection[0], size, size);
      });
    ExpectMessage(scene.Mapper, false, "vtkVolume",
      [&] { scene.Mapper->RenderEye(nullptr, 0, scene.View[0], scene.Projection[0], size, size); });
  }
  return failures == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
