// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// holovolume-denoise-benchmark: milliseconds per stereo pair of vtkStereoSpatioTemporalDenoiser
// at HoloLens 2 resolution, side by side with the path tracer's own 2-spp stereo frame in the
// same run, on the real head MRI under a real HDR panorama. Each timed frame is a new render
// (the camera orbits 0.5 degrees a frame), so the denoiser does all its work every frame.
#include "vtkDataArray.h"
#include "vtkEnvironmentMapReader.h"
#include "vtkFieldData.h"
#include "vtkHoloVolumeScene.h"
#include "vtkImageData.h"
#include "vtkIntArray.h"
#include "vtkPathTracedVolumeMapper.h"
#include "vtkSMPTools.h"
#include "vtkStereoSpatioTemporalDenoiser.h"
#include "vtkVolume.h"

#include "hv/denoise/StereoDenoiser.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

namespace
{
double Median(std::vector<double> values)
{
  std::sort(values.begin(), values.end());
  return values.empty() ? 0.0 : values[values.size() / 2];
}

// A number from an image's field data (0 when the array is missing).
double FieldNumber(vtkImageData* image, const char* name)
{
  vtkDataArray* array = image->GetFieldData()->GetArray(name);
  return array ? array->GetComponent(0, 0) : 0.0;
}

double Minimum(const std::vector<double>& values)
{
  return values.empty() ? 0.0 : *std::min_element(values.begin(), values.end());
}

void Usage()
{
  std::cout << R"(Usage: holovolume-denoise-benchmark [options]

Times vtkStereoSpatioTemporalDenoiser on stereo frames of the path tracer, next to the path
tracer's own frame time, in one run: each stage of the full denoiser; variants without D2 or
without the history; relit every frame for a change of light (with the ratio's Gaussian of a run
of changes, and of 4 pixels); relit every other frame, the first frame of a change, by the
frame's ratio to the history and by the previous light's (on the frames of a second mapper whose
environment changes every frame and which shades its paths under the previous one too, its frame
time beside the first's); relit every frame for a new transfer function, with the first scatter
scalar and coverage tests and without; and the first frames apart (where the mapper builds its
grids, and each denoiser sizes its planes and maps their pages where it first writes them: the
first frame's, then the previous frame's and the history's on the second, and the relighting's
on the first relit one).

  --volume FILE        volume (.nii, .nii.gz, .vti)
                       [/usr/share/mricron/templates/ch2.nii.gz, package mricron-data]
  --environment FILE   HDR panorama [blender-data's courtyard.exr]
  --size WxH           per eye [1440x936, HoloLens 2]
  --frames N           timed frames after two warm-up frames, 1 to 100000 [8]
  --threads N          vtkSMPTools threads, 0 (all cores) to 1024 [0]
  --wavelet-levels N   a-trous levels of the denoisers' spatial filter, 0 to 10 [the
                       denoiser's default, 4]; holovolume-denoise-evaluation takes the same
                       option, for the quality they buy
  --help               this text
)";
}
}

int main(int argc, char* argv[])
{
  std::string volumePath = holovolume::DefaultVolume();
  std::string environmentPath = holovolume::DefaultEnvironment();
  int width = 1440, height = 936, frames = 8, threads = 0;
  int waveletLevels = -1; // the denoiser's default
  const char* program = "holovolume-denoise-benchmark";
  for (int i = 1; i < argc; ++i)
  {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string
    {
      if (i + 1 >= argc)
      {
        std::cerr << "holovolume-denoise-benchmark: " << arg << " needs a value; see --help\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (arg == "--help" || arg == "-h")
    {
      Usage();
      return 0;
    }
    else if (arg == "--volume")
      volumePath = value();
    else if (arg == "--environment")
      environmentPath = value();
    else if (arg == "--size")
    {
      const std::string size = value();
      if (std::sscanf(size.c_str(), "%dx%d", &width, &height) != 2 || width < 8 || height < 8)
      {
        std::cerr << "holovolume-denoise-benchmark: --size wants WxH, e.g. 1440x936\n";
        return 2;
      }
    }
    else if (arg == "--frames")
      frames = holovolume::IntegerOption(program, "--frames", value(), 1, 100000);
    else if (arg == "--threads")
      threads = holovolume::IntegerOption(program, "--threads", value(), 0, 1024);
    else if (arg == "--wavelet-levels")
    {
      vtkNew<vtkStereoSpatioTemporalDenoiser> limits;
      waveletLevels = holovolume::IntegerOption(program, "--wavelet-levels", value(),
        limits->GetWaveletLevelsMinValue(), limits->GetWaveletLevelsMaxValue());
    }
    else
    {
      std::cerr << "holovolume-denoise-benchmark: unknown option '" << arg << "'; see --help\n";
      return 2;
    }
  }
  if (threads == 0)
  {
    threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  }
  vtkSMPTools::Initialize(threads);
  if (!holovolume::FileExists(volumePath) || !holovolume::FileExists(environmentPath))
  {
    std::cerr << "holovolume-denoise-benchmark: input missing; install mricron-data and "
                 "blender-data (apt-get install mricron-data blender-data) or pass --volume "
                 "and --environment.\n";
    return 1;
  }
  vtkSmartPointer<vtkImageData> volumeData = holovolume::ReadVolume(volumePath);
  if (!volumeData)
  {
    std::cerr << "holovolume-denoise-benchmark: could not read '" << volumePath << "'\n";
    return 1;
  }
  double range[2];
  volumeData->GetScalarRange(range);
  vtkNew<vtkVolumeProperty> property;
  holovolume::ApplyHeadMRIPreset(property, range[1] > 0 ? range[1] : 255.0);
  vtkNew<vtkEnvironmentMapReader> environment;
  environment->SetFileName(environmentPath.c_str());
  vtkNew<vtkPathTracedVolumeMapper> mapper;
  mapper->SetInputData(volumeData);
  mapper->SetEnvironmentMapConnection(environment->GetOutputPort());
  vtkNew<vtkMatrix4x4> environmentToWorld;
  holovolume::EnvironmentToRASWorld(environmentToWorld, 0.0);
  mapper->SetEnvironmentToWorldMatrix(environmentToWorld);
  mapper->ProgressiveAccumulationOff();
  vtkNew<vtkVolume> volume;
  volume->SetMapper(mapper);
  volume->SetProperty(property);
  // The same frames with the environment's intensity changed every frame (1 and 1.25 in turn),
  // the paths shaded also under the previous frame's light (RenderPreviousLighting).
  vtkNew<vtkPathTracedVolumeMapper> relitMapper;
  relitMapper->SetInputData(volumeData);
  relitMapper->SetEnvironmentMapConnection(environment->GetOutputPort());
  relitMapper->SetEnvironmentToWorldMatrix(environmentToWorld);
  relitMapper->ProgressiveAccumulationOff();
  relitMapper->RenderPreviousLightingOn();
  vtkNew<vtkVolume> relitVolume;
  relitVolume->SetMapper(relitMapper);
  relitVolume->SetProperty(property);

  struct Variant
  {
    const char* Name = "";
    vtkNew<vtkStereoSpatioTemporalDenoiser> Denoiser;
    std::vector<double> Milliseconds;
    std::vector<double> StageMilliseconds[vtkStereoSpatioTemporalDenoiser::NumberOfStages];
    std::vector<double> FirstMilliseconds; // frames 1 to 3, apart
  };
  Variant variants[10];
  variants[0].Name = "full (D1 + D2)";
  variants[1].Name = "D1 (no D2)";
  variants[2].Name = "spatial only";
  // Told every frame that the light changed (T = 0.3): the history is relit each frame.
  variants[3].Name = "full, relit every frame";
  variants[3].Denoiser->SetIlluminationDifference(0.3);
  // Every pixel through every wavelet level, as before WaveletLongHistory: what the default's
  // skipping of the last level for long histories saves.
  variants[4].Name = "full, every level for every pixel";
  variants[4].Denoiser->SetWaveletLongHistory(0.0);
  // A new transfer function every frame (the images' ClassificationStamp changes, their
  // DataStamp does not), the history relit for it, with the first scatter scalar and coverage
  // tests and without: an editor's drag of a window or opacity control.
  variants[5].Name = "full, new transfer function every frame, relit";
  variants[5].Denoiser->RelightHistoryOnTransferFunctionChangeOn();
  variants[6].Name = "the same without the scalar and coverage tests";
  variants[6].Denoiser->RelightHistoryOnTransferFunctionChangeOn();
  variants[6].Denoiser->SetClassificationScalarTolerance(0.0);
  variants[6].Denoiser->SetClassificationCoverageWidth(0.0);
  // A change of light every other frame (T = 0.3 and 0 in turns, set in the loop), each the first
  // of its run: relit by the previous light's ratio on relitMapper's frames, and by the frame's
  // ratio on the others (the frames between are refinements in both).
  variants[7].Name = "full, relit every other frame from the previous light";
  variants[8].Name = "full, relit every other frame from the frame";
  // Relit every frame as above, the ratio's Gaussian of RelightingRadius (4 pixels) on every
  // frame of the run instead of a sixtieth of the image's height: what the wider one costs.
  variants[9].Name = "full, relit every frame, ratio of 4 pixels";
  variants[9].Denoiser->SetIlluminationDifference(0.3);
  variants[9].Denoiser->SetRelightingRunHeightFraction(0.0);
  variants[1].Denoiser->StereoBlendOff();
  variants[2].Denoiser->CrossViewSamplesOff();
  variants[2].Denoiser->TemporalAccumulationOff();
  variants[2].Denoiser->StereoBlendOff();
  for (Variant& v : variants)
  {
    if (waveletLevels >= 0)
    {
      v.Denoiser->SetWaveletLevels(waveletLevels);
    }
  }

  std::vector<double> renderMs, relitRenderMs;
  // The first frames apart: the mapper builds its grids, each denoiser sizes its planes (about
  // 90 floats a pixel per eye), whose pages cost faults where the stages first write them: on
  // the first frame the current frame's, on the second the previous frame's and history's,
  // which the first frame's become on the commit, and on a relit frame the relighting's.
  double firstRenderMs = 0.0;
  const double aspect = static_cast<double>(width) / height;
  std::cerr << "rendering and denoising " << frames + 2 << " stereo frames at " << width << "x"
            << height << " per eye";
  for (int frame = 0; frame < frames + 2; ++frame)
  {
    vtkNew<vtkCamera> camera;
    holovolume::FrameHead(camera, volumeData, 35.0 + 0.5 * frame);
    vtkNew<vtkMatrix4x4> views[2];
    vtkNew<vtkMatrix4x4> projections[2];
    for (int eye = 0; eye < 2; ++eye)
    {
      holovolume::StereoEyeMatrices(camera, aspect, 64.0, eye, views[eye], projections[eye]);
    }
    const auto start = std::chrono::steady_clock::now();
    mapper->RenderStereoFrame(volume, views[0], projections[0], views[1], projections[1], width,
      height);
    const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    relitMapper->SetEnvironmentIntensity(frame % 2 ? 1.25 : 1.0);
    const auto relitStart = std::chrono::steady_clock::now();
    relitMapper->RenderStereoFrame(
      relitVolume, views[0], projections[0], views[1], projections[1], width, height);
    const double relitMs =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - relitStart)
        .count();
    // The eye images with a ClassificationStamp of their own for every frame.
    vtkNew<vtkImageData> restamped[2];
    for (int eye = 0; eye < 2; ++eye)
    {
      restamped[eye]->ShallowCopy(mapper->GetEyeOutput(eye));
      vtkNew<vtkFieldData> fields;
      fields->DeepCopy(mapper->GetEyeOutput(eye)->GetFieldData());
      vtkNew<vtkIntArray> stamp;
      stamp->SetName("ClassificationStamp");
      stamp->InsertNextValue(1000000 + frame);
      fields->RemoveArray("ClassificationStamp");
      fields->AddArray(stamp);
      restamped[eye]->SetFieldData(fields);
    }
    for (Variant& v : variants)
    {
      const bool newTransferFunction = &v == &variants[5] || &v == &variants[6];
      vtkPathTracedVolumeMapper* source = &v == &variants[7] ? relitMapper.Get() : mapper.Get();
      if (&v == &variants[7] || &v == &variants[8])
      {
        v.Denoiser->SetIlluminationDifference(frame % 2 == 0 ? 0.3 : 0.0);
      }
      v.Denoiser->SetInputData(0, newTransferFunction ? restamped[0] : source->GetEyeOutput(0));
      v.Denoiser->SetInputData(1, newTransferFunction ? restamped[1] : source->GetEyeOutput(1));
      v.Denoiser->Update();
      if (frame < 3)
      {
        v.FirstMilliseconds.push_back(v.Denoiser->GetLastFrameMilliseconds());
      }
      if (frame >= 2)
      {
        v.Milliseconds.push_back(v.Denoiser->GetLastFrameMilliseconds());
        for (int stage = 0; stage < vtkStereoSpatioTemporalDenoiser::NumberOfStages; ++stage)
        {
          v.StageMilliseconds[stage].push_back(v.Denoiser->GetLastStageMilliseconds(stage));
        }
      }
    }
    if (frame == 0)
    {
      firstRenderMs = ms;
    }
    if (frame >= 2)
    {
      renderMs.push_back(ms);
      relitRenderMs.push_back(relitMs);
    }
    std::cerr << "." << std::flush;
  }
  std::cerr << "\n" << std::flush;

  int dims[3];
  volumeData->GetDimensions(dims);
  std::printf("\nholovolume-denoise-benchmark: %s %dx%dx%d, %dx%d per eye, stereo, 2 spp, "
              "threads=%d, SMP backend %s, denoiser tuned for %s\n",
    volumePath.substr(volumePath.find_last_of('/') + 1).c_str(), dims[0], dims[1], dims[2], width,
    height, threads, vtkSMPTools::GetBackend(), hv::denoise::StereoDenoiser::tuning());
  std::printf("wavelet levels: %d%s\n", variants[0].Denoiser->GetWaveletLevels(),
    waveletLevels >= 0 ? " (--wavelet-levels)" : " (the denoiser's default)");
  std::printf("median of %d frames (each a new view), wall-clock ms per stereo pair\n\n", frames);
  std::printf("%-56s %12s %12s\n", "", "median ms", "min ms");
  std::printf("%-56s %12.1f %12.1f\n", "vtkPathTracedVolumeMapper, 2 spp stereo frame",
    Median(renderMs), Minimum(renderMs));
  std::printf("%-56s %12.1f %12.1f\n", "  the same, light changed, previous light shaded too",
    Median(relitRenderMs), Minimum(relitRenderMs));
  for (Variant& v : variants)
  {
    std::printf("%-56s %12.1f %12.1f\n",
      (std::string("vtkStereoSpatioTemporalDenoiser, ") + v.Name).c_str(), Median(v.Milliseconds),
      Minimum(v.Milliseconds));
  }
  std::printf("\nfirst frames, ms (the mapper builds its grids; a denoiser sizes its planes, "
              "and its stages write pages no frame before wrote)\n");
  std::printf("%-56s %12.1f\n", "vtkPathTracedVolumeMapper, first frame", firstRenderMs);
  std::printf("%-56s %12s\n", "", "frame 1 / 2 / 3");
  for (const Variant* v : { &variants[0], &variants[3] })
  {
    std::printf("%-56s %6.0f / %.0f / %.0f\n",
      (std::string("vtkStereoSpatioTemporalDenoiser, ") + v->Name).c_str(), v->FirstMilliseconds[0],
      v->FirstMilliseconds[1], v->FirstMilliseconds[2]);
  }
  static const char* stageNames[vtkStereoSpatioTemporalDenoiser::NumberOfStages] = { "surfaces",
    "D1 cross-view samples", "D1 temporal blending", "D1 wavelet filter", "D2" };
  // Beside it the relit frames' stages: the relighting (the ratio's blurs) runs inside the
  // temporal blending's stage.
  std::printf(
    "\nfull denoiser by stage; %.1f%% of the pixels see the volume\n%-56s %12s %12s %12s\n",
    50.0 *
      (variants[0].Denoiser->GetLastSurfaceFraction(0) +
        variants[0].Denoiser->GetLastSurfaceFraction(1)),
    "", "median ms", "min ms", "relit, median");
  for (int stage = 0; stage < vtkStereoSpatioTemporalDenoiser::NumberOfStages; ++stage)
  {
    // The minimum too: on a shared machine other work only ever adds time, so the minimum is
    // the steadier figure when two builds are compared.
    std::printf("  %-54s %12.1f %12.1f %12.1f\n", stageNames[stage],
      Median(variants[0].StageMilliseconds[stage]), Minimum(variants[0].StageMilliseconds[stage]),
      Median(variants[3].StageMilliseconds[stage]));
  }
  // Paired frame by frame, so that what the machine's load adds to both cancels.
  std::vector<double> everyLevelMore;
  for (std::size_t f = 0; f < variants[0].Milliseconds.size(); ++f)
  {
    everyLevelMore.push_back(
      variants[4].StageMilliseconds[vtkStereoSpatioTemporalDenoiser::WaveletStage][f] -
      variants[0].StageMilliseconds[vtkStereoSpatioTemporalDenoiser::WaveletStage][f]);
  }
  std::printf("\nThe wavelet filter with every level for every pixel: median %.1f ms, %.1f ms more "
              "than with the last level skipped where the history holds %g frames or more "
              "(median of the frames' differences).\n",
    Median(variants[4].StageMilliseconds[vtkStereoSpatioTemporalDenoiser::WaveletStage]),
    Median(everyLevelMore), variants[0].Denoiser->GetWaveletLongHistory());
  std::vector<double> classificationTestsMore;
  for (std::size_t f = 0; f < variants[5].Milliseconds.size(); ++f)
  {
    classificationTestsMore.push_back(variants[5].Milliseconds[f] - variants[6].Milliseconds[f]);
  }
  std::printf("\nA new transfer function every frame, the history relit: median %.1f ms; the first "
              "scatter scalar and coverage tests add %.1f ms (median of the frames' differences); "
              "they dropped %.1f%% of the histories on the last frame (the same transfer function, "
              "so only noise and the view's motion).\n",
    Median(variants[5].Milliseconds), Median(classificationTestsMore),
    50.0 *
      (FieldNumber(variants[5].Denoiser->GetEyeOutput(0), "MaterialChangedFraction") +
        FieldNumber(variants[5].Denoiser->GetEyeOutput(1), "MaterialChangedFraction")));
  // Timed frames start at frame 2, so the even entries are the changes.
  std::vector<double> relitFromPreviousLight, relitFromFrame, previousLightMore,
    previousLightRenderMore;
  for (std::size_t f = 0; f < variants[7].Milliseconds.size(); ++f)
  {
    previousLightRenderMore.push_back(relitRenderMs[f] - renderMs[f]);
    if (f % 2 == 0)
    {
      relitFromPreviousLight.push_back(variants[7].Milliseconds[f]);
      relitFromFrame.push_back(variants[8].Milliseconds[f]);
      previousLightMore.push_back(variants[7].Milliseconds[f] - variants[8].Milliseconds[f]);
    }
  }
  std::printf("\nThe light changed every frame, the paths shaded also under the previous one: the "
              "path tracer's frame %.1f ms more (median of the frames' differences). The first "
              "frame of a change relit by that light's ratio: median %.1f ms, by the frame's "
              "ratio %.1f, %.1f ms more (median of the changes' differences).\n",
    Median(previousLightRenderMore), Median(relitFromPreviousLight), Median(relitFromFrame),
    Median(previousLightMore));
  std::printf("\nThe full denoiser costs %.1f%% of the frame it denoises.\n",
    100.0 * Median(variants[0].Milliseconds) / Median(renderMs));
  return 0;
}
