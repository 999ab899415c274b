// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// What a new transfer function does to the denoiser's history, on path-traced stereo frames of
// the synthetic test volume (2 samples per pixel and frame) against a 512-spp reference:
// 1. by default the history is dropped: the frame after the change has a history of one frame;
// 2. with RelightHistoryOnTransferFunctionChange the history is relit instead: it keeps at
//    least half its length, and the frame gains at least 3 dB over the dropped history's
//    (measured at 64x64: 29.7 dB against 25.9, raw 16.3; history 4.5 frames, 4.1 before);
// 3. new data drops the history even then (the mapper's "DataStamp" changed);
// 4. images without a "DataStamp" cannot tell new data from a new transfer function, and drop it;
// 5. the first scatter scalar test: a recolouring (the same surfaces) drops at most a tenth of
//    the pixels' histories; where the images' "FirstScatterScalar" says the material changed
//    (here moved by 0.5 on the left half of each eye's image, on the frame of the change), those
//    pixels start over, and "MaterialChangedFraction" counts them.
#include "DenoiserTestImages.h"
#include "PathTracingTestScene.h"
#include "vtkStereoSpatioTemporalDenoiser.h"

#include "hv/denoise/ImageQuality.h"

#include "vtkColorTransferFunction.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkPointData.h"
#include "vtkUnsignedCharArray.h"

#include <cmath>
#include <iostream>
#include <vector>

namespace
{
constexpr int Size = 64;

using denoisertest::Display;
using denoisertest::FieldValue;

// The new transfer function: the shell turns from skin tones to grey-blue, the core from blue
// to orange, the opacities stay (so the surfaces stay where they were).
void Recolour(vtkVolumeProperty* property)
{
  vtkColorTransferFunction* color = property->GetRGBTransferFunction();
  color->RemoveAllPoints();
  color->AddRGBPoint(0, 0.5, 0.6, 0.8);
  color->AddRGBPoint(1000, 0.45, 0.55, 0.85);
  color->AddRGBPoint(2000, 0.95, 0.6, 0.2);
}

// The stereo reference of the recoloured volume: 64 spp x 8 progressive frames.
void RenderReference(std::vector<float> reference[2])
{
  pathtracingtest::OffscreenScene scene;
  Recolour(scene.Property);
  scene.Mapper->SetSamplesPerPixel(64);
  scene.Mapper->SetSeed(4321);
  for (int frame = 0; frame < 8; ++frame)
  {
    scene.RenderStereo(Size);
  }
  for (int e = 0; e < 2; ++e)
  {
    reference[e] = Display(scene.Mapper->GetEyeOutput(e));
  }
}

double StereoPSNR(vtkStereoSpatioTemporalDenoiser* denoiser, const std::vector<float> reference[2])
{
  return 0.5 *
    (hv::denoise::displayPSNR(Display(denoiser->GetEyeOutput(0)), reference[0]) +
      hv::denoise::displayPSNR(Display(denoiser->GetEyeOutput(1)), reference[1]));
}
}

int TestStereoSpatioTemporalDenoiserTransferFunction(int, char*[])
{
  int failures = 0;
  std::vector<float> reference[2];
  RenderReference(reference);

  pathtracingtest::OffscreenScene scene;
  scene.Mapper->ProgressiveAccumulationOff();
  vtkNew<vtkStereoSpatioTemporalDenoiser> dropping, relighting, otherMaterial;
  relighting->RelightHistoryOnTransferFunctionChangeOn();
  otherMaterial->RelightHistoryOnTransferFunctionChangeOn();
  if (dropping->GetRelightHistoryOnTransferFunctionChange())
  {
    std::cerr << "FAILED: RelightHistoryOnTransferFunctionChange is on by default\n";
    ++failures;
  }
  for (vtkStereoSpatioTemporalDenoiser* denoiser :
    { dropping.Get(), relighting.Get(), otherMaterial.Get() })
  {
    denoiser->SetInputData(0, scene.Mapper->GetEyeOutput(0));
    denoiser->SetInputData(1, scene.Mapper->GetEyeOutput(1));
  }
  auto frame = [&]()
  {
    scene.RenderStereo(Size);
    dropping->Update();
    relighting->Update();
  };
  for (int k = 0; k < 8; ++k)
  {
    frame();
    otherMaterial->Update();
  }
  const double lengthBefore = FieldValue(relighting->GetEyeOutput(0), "MeanHistoryLength");

  // 1 and 2. The new colours.
  Recolour(scene.Property);
  frame();
  // 5. The same frame with other material on the left half of each eye.
  vtkNew<vtkImageData> shifted[2];
  double leftHalfShare[2] = { 0.0, 0.0 };
  for (int e = 0; e < 2; ++e)
  {
    vtkImageData* eye = scene.Mapper->GetEyeOutput(e);
    shifted[e]->ShallowCopy(eye);
    vtkNew<vtkFloatArray> scalar;
    scalar->DeepCopy(eye->GetPointData()->GetArray("FirstScatterScalar"));
    auto* valid =
      vtkUnsignedCharArray::SafeDownCast(eye->GetPointData()->GetArray("FirstScatterValid"));
    int seen = 0, moved = 0;
    for (vtkIdType i = 0; i < scalar->GetNumberOfTuples(); ++i)
    {
      if (valid->GetValue(i))
      {
        ++seen;
        if (i % Size < Size / 2)
        {
          scalar->SetValue(i, std::fmod(scalar->GetValue(i) + 0.5f, 1.0f));
          ++moved;
        }
      }
    }
    leftHalfShare[e] = static_cast<double>(moved) / seen;
    vtkNew<vtkPointData> points;
    points->ShallowCopy(eye->GetPointData());
    points->RemoveArray("FirstScatterScalar");
    points->AddArray(scalar);
    shifted[e]->GetPointData()->ShallowCopy(points);
    otherMaterial->SetInputData(e, shifted[e]);
  }
  otherMaterial->Update();
  const double raw = 0.5 *
    (hv::denoise::displayPSNR(Display(scene.Mapper->GetEyeOutput(0)), reference[0]) +
      hv::denoise::displayPSNR(Display(scene.Mapper->GetEyeOutput(1)), reference[1]));
  const double droppedPSNR = StereoPSNR(dropping, reference);
  const double relitPSNR = StereoPSNR(relighting, reference);
  const double droppedLength = FieldValue(dropping->GetEyeOutput(0), "MeanHistoryLength");
  const double relitLength = FieldValue(relighting->GetEyeOutput(0), "MeanHistoryLength");
  std::cout << "new colours after 8 frames (history " << lengthBefore << " frames): raw " << raw
            << " dB; history dropped " << droppedPSNR << " dB (" << droppedLength
            << " frames); relit " << relitPSNR << " dB (" << relitLength << " frames)\n";
  if (droppedLength > 1.01)
  {
    std::cerr << "FAILED: by default a new transfer function does not drop the history\n";
    ++failures;
  }
  if (relitLength < 0.5 * lengthBefore || relitPSNR < droppedPSNR + 3.0)
  {
    std::cerr << "FAILED: RelightHistoryOnTransferFunctionChange did not keep the history, or "
                 "kept it without gaining 3 dB\n";
    ++failures;
  }
  for (int e = 0; e < 2; ++e)
  {
    const double recoloured = FieldValue(relighting->GetEyeOutput(e), "MaterialChangedFraction");
    const double moved = FieldValue(otherMaterial->GetEyeOutput(e), "MaterialChangedFraction");
    std::cout << "eye " << e << ": the scalar test dropped " << recoloured
              << " of the histories for the new colours, " << moved
              << " where the left half's material changed (" << leftHalfShare[e]
              << " of the pixels that see the volume)\n";
    if (!(recoloured < 0.1))
    {
      std::cerr << "FAILED: the scalar test dropped the history of the same surfaces\n";
      ++failures;
    }
    if (!(moved > recoloured + 0.7 * leftHalfShare[e] && moved < recoloured + leftHalfShare[e]))
    {
      std::cerr << "FAILED: the scalar test did not drop the history where the material changed\n";
      ++failures;
    }
  }

  // 3. New data: the same values in a new image, which the mapper quantises again.
  frame();
  scene.Mapper->SetInputData(pathtracingtest::MakeVolume());
  frame();
  const double newDataLength = FieldValue(relighting->GetEyeOutput(0), "MeanHistoryLength");
  std::cout << "new data: history " << newDataLength << " frames\n";
  if (newDataLength > 1.01)
  {
    std::cerr << "FAILED: new data did not drop the relighting denoiser's history\n";
    ++failures;
  }

  // 4. Images without a "DataStamp": a new transfer function drops the history.
  for (int k = 0; k < 4; ++k)
  {
    frame();
  }
  vtkNew<vtkImageData> eyes[2];
  auto strip = [&]()
  {
    for (int e = 0; e < 2; ++e)
    {
      eyes[e]->ShallowCopy(scene.Mapper->GetEyeOutput(e));
      vtkNew<vtkFieldData> fields;
      fields->ShallowCopy(scene.Mapper->GetEyeOutput(e)->GetFieldData());
      fields->RemoveArray("DataStamp");
      eyes[e]->SetFieldData(fields);
      relighting->SetInputData(e, eyes[e]);
    }
    relighting->Update();
  };
  scene.RenderStereo(Size);
  strip();
  scene.Property->GetScalarOpacity()->AddPoint(500, 0.01);
  scene.RenderStereo(Size);
  strip();
  const double unstampedLength = FieldValue(relighting->GetEyeOutput(0), "MeanHistoryLength");
  std::cout << "new transfer function without a DataStamp: history " << unstampedLength
            << " frames\n";
  if (unstampedLength > 1.01)
  {
    std::cerr << "FAILED: without a DataStamp a new transfer function did not drop the history\n";
    ++failures;
  }
  return failures == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
