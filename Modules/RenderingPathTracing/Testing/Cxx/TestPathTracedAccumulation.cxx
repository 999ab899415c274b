// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Progressive rendering: frames accumulate while nothing changes and the error against a
// high-sample reference falls; a change of camera, transfer function, environment, lights or
// rendering settings (the subpixel samples among them) restarts the accumulation, a
// display-only change (exposure) does not. Progress events rise monotonically to 1 and the
// frame index counts every frame. The images' "ClassificationStamp" (on which a denoiser drops
// its history) changes with the transfer function and the data, and not when the property's
// MTime moves with nothing in it changed (vtkVolume::SetProperty on a second volume), which
// keeps accumulating too; "DataStamp" changes with the data alone.
#include "PathTracingTestScene.h"

#include "vtkCallbackCommand.h"
#include "vtkCommand.h"
#include "vtkDataArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkLight.h"
#include "vtkLightCollection.h"

#include <iostream>
#include <vector>

namespace
{
struct ProgressLog
{
  std::vector<double> Values;
  int Starts = 0;
  int Ends = 0;
};

void OnEvent(vtkObject* caller, unsigned long event, void* clientData, void*)
{
  auto* log = static_cast<ProgressLog*>(clientData);
  if (event == vtkCommand::ProgressEvent)
  {
    log->Values.push_back(static_cast<vtkAlgorithm*>(caller)->GetProgress());
  }
  else if (event == vtkCommand::StartEvent)
  {
    ++log->Starts;
  }
  else if (event == vtkCommand::EndEvent)
  {
    ++log->Ends;
  }
}

std::vector<float> Radiance(vtkPathTracedVolumeMapper* mapper)
{
  auto* array =
    vtkFloatArray::SafeDownCast(mapper->GetEyeOutput(0)->GetPointData()->GetArray("Radiance"));
  return std::vector<float>(
    array->GetPointer(0), array->GetPointer(0) + array->GetNumberOfValues());
}

double RootMeanSquareError(const std::vector<float>& a, const std::vector<float>& b)
{
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
  {
    sum += (a[i] - b[i]) * (a[i] - b[i]);
  }
  return std::sqrt(sum / a.size());
}
}

int TestPathTracedAccumulation(int, char*[])
{
  const int size = 48;
  int failures = 0;
  auto expect = [&](bool condition, const char* what)
  {
    if (!condition)
    {
      std::cerr << "FAILED: " << what << "\n";
      ++failures;
    }
  };

  // Reference: one frame of many samples.
  pathtracingtest::OffscreenScene reference;
  reference.Mapper->SetSamplesPerPixel(256);
  reference.Mapper->SetSeed(1000);
  reference.Mapper->RenderEye(
    reference.Volume, 0, reference.View[0], reference.Projection[0], size, size);
  const std::vector<float> converged = Radiance(reference.Mapper);

  pathtracingtest::OffscreenScene scene;
  ProgressLog log;
  vtkNew<vtkCallbackCommand> callback;
  callback->SetCallback(OnEvent);
  callback->SetClientData(&log);
  scene.Mapper->AddObserver(vtkCommand::ProgressEvent, callback);
  scene.Mapper->AddObserver(vtkCommand::StartEvent, callback);
  scene.Mapper->AddObserver(vtkCommand::EndEvent, callback);
  auto render = [&]()
  {
    return scene.Mapper->RenderEye(scene.Volume, 0, scene.View[0], scene.Projection[0], size, size);
  };

  std::vector<double> errors;
  for (int frame = 1; frame <= 16; ++frame)
  {
    render();
    expect(scene.Mapper->GetAccumulatedFrames(0) == frame,
      "accumulated frames count up while nothing changes");
    if (frame == 1 || frame == 4 || frame == 16)
    {
      errors.push_back(RootMeanSquareError(Radiance(scene.Mapper), converged));
    }
  }
  std::cout << "RMSE after 1, 4, 16 frames: " << errors[0] << " " << errors[1] << " " << errors[2]
            << "\n";
  // Monte-Carlo error falls as 1/sqrt(frames): 16 frames should at least halve it twice over
  // (ratio 4 ideal; 2.5 leaves room for the reference's own noise).
  expect(errors[0] / errors[2] > 2.5, "error falls with accumulated frames");
  expect(scene.Mapper->GetFrameIndex() == 16, "the frame index counts rendered frames");

  // Progress events: monotone within each frame, ending at 1.
  bool monotone = true;
  for (std::size_t i = 1; i < log.Values.size(); ++i)
  {
    if (log.Values[i] < log.Values[i - 1] && log.Values[i] != 0.0)
    {
      monotone = false;
    }
  }
  expect(!log.Values.empty() && log.Values.back() == 1.0 && monotone, "progress rises to 1");
  expect(log.Starts == 16 && log.Ends == 16, "one StartEvent and one EndEvent per frame");

  // Display-only changes keep the accumulation.
  scene.Mapper->SetExposure(1.5);
  render();
  expect(scene.Mapper->GetAccumulatedFrames(0) == 17, "changing the exposure keeps accumulating");

  // Camera change restarts.
  render();
  scene.View[0]->SetElement(0, 3, scene.View[0]->GetElement(0, 3) + 0.5);
  render();
  expect(scene.Mapper->GetAccumulatedFrames(0) == 1, "a camera change restarts the accumulation");

  // Transfer-function change restarts.
  auto stamp = [&](const char* name)
  {
    vtkDataArray* array = scene.Mapper->GetEyeOutput(0)->GetFieldData()->GetArray(name);
    return array ? static_cast<int>(array->GetComponent(0, 0)) : -1;
  };
  render();
  const int classificationBefore = stamp("ClassificationStamp");
  const int dataBefore = stamp("DataStamp");
  scene.Property->GetScalarOpacity()->AddPoint(1500, 0.5);
  render();
  expect(scene.Mapper->GetAccumulatedFrames(0) == 1,
    "a transfer-function change restarts the accumulation");
  expect(stamp("ClassificationStamp") != classificationBefore && stamp("DataStamp") == dataBefore,
    "a transfer-function change changes the ClassificationStamp and not the DataStamp");

  // The property put on a second volume: vtkVolume::SetProperty calls its UpdateMTimes(), so
  // its MTime moves, but nothing in it changed.
  const int classificationNow = stamp("ClassificationStamp");
  const vtkMTimeType propertyTime = scene.Property->GetMTime();
  const int framesBeforeTouch = scene.Mapper->GetAccumulatedFrames(0);
  vtkNew<vtkVolume> second;
  second->SetProperty(scene.Property);
  expect(scene.Property->GetMTime() != propertyTime, "SetProperty touches the property");
  render();
  expect(stamp("ClassificationStamp") == classificationNow,
    "a property touched without a change keeps the ClassificationStamp");
  expect(scene.Mapper->GetAccumulatedFrames(0) == framesBeforeTouch + 1,
    "a property touched without a change keeps accumulating");
  // So does a property set to what it already holds and modified; a new shading coefficient,
  // which the path tracer reads, restarts.
  scene.Property->SetScalarOpacity(scene.Property->GetScalarOpacity());
  scene.Property->Modified();
  render();
  expect(scene.Mapper->GetAccumulatedFrames(0) == framesBeforeTouch + 2,
    "a property modified without a change keeps accumulating");
  scene.Property->SetDiffuse(scene.Property->GetDiffuse() * 0.5);
  render();
  expect(scene.Mapper->GetAccumulatedFrames(0) == 1,
    "a new diffuse coefficient restarts the accumulation");
  expect(stamp("ClassificationStamp") == classificationNow,
    "a new diffuse coefficient keeps the ClassificationStamp");

  // Environment change restarts.
  render();
  scene.Mapper->SetEnvironmentMapData(pathtracingtest::MakeSky(64, 800));
  render();
  expect(scene.Mapper->GetAccumulatedFrames(0) == 1, "a new environment restarts the accumulation");

  // New data restarts.
  render();
  auto* input = vtkImageData::SafeDownCast(scene.Mapper->GetInput());
  static_cast<unsigned short*>(input->GetScalarPointer(24, 24, 24))[0] = 0;
  input->GetPointData()->GetScalars()->Modified();
  input->Modified();
  render();
  expect(
    scene.Mapper->GetAccumulatedFrames(0) == 1, "modified input data restarts the accumulation");
  expect(stamp("ClassificationStamp") != classificationNow && stamp("DataStamp") != dataBefore,
    "new data changes both stamps");

  // A change of the lights restarts.
  vtkNew<vtkLightCollection> lights;
  vtkNew<vtkLight> light;
  light->SetPosition(0, 0, 50);
  light->SetFocalPoint(0, 0, 0);
  lights->AddItem(light);
  auto renderLit = [&]()
  {
    return scene.Mapper->RenderEye(
      scene.Volume, 0, scene.View[0], scene.Projection[0], size, size, lights);
  };
  renderLit();
  renderLit();
  expect(scene.Mapper->GetAccumulatedFrames(0) == 2, "unchanged lights keep accumulating");
  light->SetIntensity(0.5);
  renderLit();
  expect(scene.Mapper->GetAccumulatedFrames(0) == 1, "a light change restarts the accumulation");

  // Rendering setting change restarts; explicit reset too.
  render();
  scene.Mapper->SetAnisotropy(0.5);
  render();
  expect(scene.Mapper->GetAccumulatedFrames(0) == 1, "a new anisotropy restarts the accumulation");
  // Where the samples enter their pixels is a rendering setting too: switching the stratified
  // subpixel positions off restarts, and the same frame index and seed then give another image
  // (the positions reach the kernel; the paths' other random numbers are the same either way).
  scene.Mapper->SetFrameIndex(100);
  render();
  const std::vector<float> stratifiedFrame = Radiance(scene.Mapper);
  scene.Mapper->StratifiedSubpixelSamplesOff();
  scene.Mapper->SetFrameIndex(100);
  render();
  expect(scene.Mapper->GetAccumulatedFrames(0) == 1,
    "switching the stratified subpixel samples restarts the accumulation");
  expect(RootMeanSquareError(Radiance(scene.Mapper), stratifiedFrame) > 0.0,
    "the subpixel samples setting reaches the renderer");
  scene.Mapper->StratifiedSubpixelSamplesOn();
  render();
  scene.Mapper->ResetAccumulation();
  render();
  expect(scene.Mapper->GetAccumulatedFrames(0) == 1, "ResetAccumulation restarts");

  // Without progressive accumulation every frame stands alone.
  scene.Mapper->ProgressiveAccumulationOff();
  render();
  render();
  expect(scene.Mapper->GetAccumulatedFrames(0) == 1,
    "no accumulation when ProgressiveAccumulation is off");

  // A restart writes the new frame's samples over the old sum (which is not zeroed first): after
  // 8 frames and ResetAccumulation(), a frame is as far from the converged image as a first
  // frame is, not 9 frames' radiance over one; the same after 8 frames at a larger size.
  for (const int earlierSize : { size, size + 16 })
  {
    pathtracingtest::OffscreenScene restarted;
    for (int frame = 0; frame < 8; ++frame)
    {
      restarted.Mapper->RenderEye(
        restarted.Volume, 0, restarted.View[0], restarted.Projection[0], earlierSize, earlierSize);
    }
    restarted.Mapper->ResetAccumulation();
    restarted.Mapper->RenderEye(
      restarted.Volume, 0, restarted.View[0], restarted.Projection[0], size, size);
    const double error = RootMeanSquareError(Radiance(restarted.Mapper), converged);
    std::cout << "RMSE of a frame after 8 frames at " << earlierSize << "x" << earlierSize
              << " and a restart: " << error << " (first frame " << errors[0] << ")\n";
    expect(std::abs(error / errors[0] - 1.0) < 0.25,
      "a restarted sum holds the new frame's samples only");
  }
  return failures == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
