// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// holovolume: path-traced stereo renders of a CT/MRI volume under an HDR environment,
// written to PNG (and optionally the HDR/auxiliary buffers to .vti). Later versions grow
// this into the full mixed-reality pipeline.
#include "vtkHoloVolumeScene.h"

#include "vtkCallbackCommand.h"
#include "vtkCommand.h"
#include "vtkEnvironmentMapReader.h"
#include "vtkImageAppend.h"
#include "vtkImageData.h"
#include "vtkLight.h"
#include "vtkLightCollection.h"
#include "vtkNew.h"
#include "vtkPNGWriter.h"
#include "vtkPathTracedVolumeMapper.h"
#include "vtkPointData.h"
#include "vtkSMPTools.h"
#include "vtkUnsignedCharArray.h"
#include "vtkVolume.h"
#include "vtkXMLImageDataWriter.h"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

namespace
{
struct Options
{
  std::string Volume = holovolume::DefaultVolume();
  std::string Environment = holovolume::DefaultEnvironment();
  std::string Output = "holovolume-output";
  std::vector<std::string> Models = { "path-traced" };
  int Width = 720;
  int Height = 468;
  int SamplesPerPixel = 2;
  int Frames = 32;
  int Bounces = 1;
  bool Stereo = true;
  double InterpupillaryDistance = 64.0;
  double Exposure = 0.0;
  std::string ToneMapping = "aces";
  double EnvironmentYaw = 0.0;
  double EnvironmentIntensity = 1.0;
  double Azimuth = 35.0;
  unsigned int Seed = 0;
  bool SaveBuffers = false;
  bool Transparent = false;
  bool ShowEnvironment = false;
  int Threads = 0;
};

void PrintHelp()
{
  std::cout <<
    R"(Usage: holovolume [options]

Renders a CT or MRI volume with HoloVolume's Monte-Carlo path tracer, lit by an HDR
environment map, for both eyes of a headset, and writes PNG images.

Defaults use real data from Debian packages: the ch2 head MRI (mricron-data) and the
'courtyard' HDR panorama (blender-data).

Input
  -v, --volume FILE          NIfTI (.nii, .nii.gz) or VTK XML image (.vti) volume
                             [/usr/share/mricron/templates/ch2.nii.gz]
  -e, --environment FILE     HDR panorama (.exr, .hdr), twice as wide as high, or
                             'uniform' for a uniform white sky
                             [/usr/share/blender/datafiles/studiolights/world/courtyard.exr]
      --environment-yaw DEG  turn the panorama about the head's up axis [0]
      --environment-intensity X  scale the environment's radiance [1]

Rendering
  -m, --model NAME           path-traced, emission-absorption, gradient-phong,
                             prefiltered-environment, or all (one image set each)
                             [path-traced]
      --width N, --height N  pixels per eye [720 x 468; HoloLens 2 is 1440 x 936]
      --spp N                samples per pixel per frame [2]
      --frames N             frames accumulated progressively [32]
      --bounces N            scatter events per path; 1 = single scattering [1]
      --mono                 one centred view instead of a stereo pair
      --ipd MM               interpupillary distance in volume units (mm) [64]
      --azimuth DEG          camera azimuth around the head (0 = face on) [35]
      --seed N               random seed [0]
      --threads N            worker threads [all cores]

Output
  -o, --output DIR           output folder [holovolume-output]
      --exposure STOPS       display exposure [0]
      --tone-mapping NAME    aces or clamp [aces]
      --transparent          keep the alpha channel instead of a dark background
      --show-environment     draw the environment behind the volume
      --save-buffers         also write each eye's HDR radiance and auxiliary buffers
                             (first-scatter position, depth, albedo, normal) as .vti
  -h, --help                 this text

Writes <model>-left.png, <model>-right.png and <model>-stereo.png (side by side) for
a stereo pair, <model>.png for --mono.
)";
}

bool ParseArguments(int argc, char* argv[], Options& options)
{
  for (int i = 1; i < argc; ++i)
  {
    const std::string argument = argv[i];
    auto value = [&](const char* name) -> const char*
    {
      if (i + 1 >= argc)
      {
        std::cerr << "holovolume: " << name << " needs a value (see --help)\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (argument == "-h" || argument == "--help")
    {
      PrintHelp();
      std::exit(0);
    }
    else if (argument == "-v" || argument == "--volume")
      options.Volume = value("--volume");
    else if (argument == "-e" || argument == "--environment")
      options.Environment = value("--environment");
    else if (argument == "--environment-yaw")
      options.EnvironmentYaw = std::atof(value("--environment-yaw"));
    else if (argument == "--environment-intensity")
      options.EnvironmentIntensity = std::atof(value("--environment-intensity"));
    else if (argument == "-o" || argument == "--output")
      options.Output = value("--output");
    else if (argument == "-m" || argument == "--model")
    {
      const std::string model = value("--model");
      if (model == "all")
        options.Models = { "path-traced", "emission-absorption", "gradient-phong",
          "prefiltered-environment" };
      else if (model == "path-traced" || model == "emission-absorption" ||
        model == "gradient-phong" || model == "prefiltered-environment")
        options.Models = { model };
      else
      {
        std::cerr << "holovolume: unknown model '" << model
                  << "'; use path-traced, emission-absorption, "
                  << "gradient-phong, prefiltered-environment or all\n";
        return false;
      }
    }
    else if (argument == "--width")
      options.Width = std::atoi(value("--width"));
    else if (argument == "--height")
      options.Height = std::atoi(value("--height"));
    else if (argument == "--spp")
      options.SamplesPerPixel = std::atoi(value("--spp"));
    else if (argument == "--frames")
      options.Frames = std::atoi(value("--frames"));
    else if (argument == "--bounces")
      options.Bounces = std::atoi(value("--bounces"));
    else if (argument == "--mono")
      options.Stereo = false;
    else if (argument == "--ipd")
      options.InterpupillaryDistance = std::atof(value("--ipd"));
    else if (argument == "--azimuth")
      options.Azimuth = std::atof(value("--azimuth"));
    else if (argument == "--seed")
      options.Seed = static_cast<unsigned int>(std::strtoul(value("--seed"), nullptr, 10));
    else if (argument == "--threads")
      options.Threads = std::atoi(value("--threads"));
    else if (argument == "--exposure")
      options.Exposure = std::atof(value("--exposure"));
    else if (argument == "--tone-mapping")
      options.ToneMapping = value("--tone-mapping");
    else if (argument == "--transparent")
      options.Transparent = true;
    else if (argument == "--show-environment")
      options.ShowEnvironment = true;
    else if (argument == "--save-buffers")
      options.SaveBuffers = true;
    else
    {
      std::cerr << "holovolume: unknown option '" << argument << "' (see --help)\n";
      return false;
    }
  }
  if (options.Width < 1 || options.Height < 1 || options.SamplesPerPixel < 1 ||
    options.Frames < 1 || options.Bounces < 1)
  {
    std::cerr << "holovolume: width, height, spp, frames and bounces must be positive\n";
    return false;
  }
  if (options.ToneMapping != "aces" && options.ToneMapping != "clamp")
  {
    std::cerr << "holovolume: --tone-mapping must be aces or clamp\n";
    return false;
  }
  return true;
}

// A one-line progress bar on stderr, fed by the mapper's ProgressEvent.
struct ProgressState
{
  std::string Label;
  int Frame = 0;
  int Frames = 1;
};

void OnProgress(vtkObject* caller, unsigned long, void* clientData, void*)
{
  auto* state = static_cast<ProgressState*>(clientData);
  if (!isatty(fileno(stderr)))
  {
    return; // no bar in logs; the per-model summary line follows
  }
  const double progress =
    (state->Frame + static_cast<vtkAlgorithm*>(caller)->GetProgress()) / state->Frames;
  const int width = 30;
  const int filled = static_cast<int>(progress * width + 0.5);
  std::fprintf(stderr, "\r  %-24s [%s%s] %3d%%  frame %d/%d", state->Label.c_str(),
    std::string(filled, '#').c_str(), std::string(width - filled, '.').c_str(),
    static_cast<int>(progress * 100.0 + 0.5), std::min(state->Frame + 1, state->Frames),
    state->Frames);
  std::fflush(stderr);
}

// Display image of an eye as RGB over a dark background, or RGBA when transparent.
vtkSmartPointer<vtkImageData> DisplayImage(
  vtkPathTracedVolumeMapper* mapper, int eye, bool transparent)
{
  vtkNew<vtkImageData> rgba;
  mapper->ComputeDisplayImage(eye, rgba);
  if (transparent)
  {
    return rgba.Get();
  }
  int dims[3];
  rgba->GetDimensions(dims);
  auto rgb = vtkSmartPointer<vtkImageData>::New();
  rgb->SetDimensions(dims[0], dims[1], 1);
  rgb->AllocateScalars(VTK_UNSIGNED_CHAR, 3);
  const unsigned char* source = static_cast<unsigned char*>(rgba->GetScalarPointer());
  unsigned char* target = static_cast<unsigned char*>(rgb->GetScalarPointer());
  const unsigned char background = 26; // sRGB ~0.1: dark grey, like a dimmed room
  for (vtkIdType i = 0; i < static_cast<vtkIdType>(dims[0]) * dims[1]; ++i)
  {
    const int alpha = source[4 * i + 3];
    for (int c = 0; c < 3; ++c)
    {
      // Premultiplied colour over the background.
      target[3 * i + c] = static_cast<unsigned char>(
        std::min(255, source[4 * i + c] + (255 - alpha) * background / 255));
    }
  }
  return rgb;
}

void WritePNG(vtkImageData* image, const std::string& path)
{
  vtkNew<vtkPNGWriter> writer;
  writer->SetInputData(image);
  writer->SetFileName(path.c_str());
  writer->Write();
}
}

int main(int argc, char* argv[])
{
  Options options;
  if (!ParseArguments(argc, argv, options))
  {
    return 2;
  }
  if (options.Threads > 0)
  {
    vtkSMPTools::Initialize(options.Threads);
  }
  if (!holovolume::FileExists(options.Volume))
  {
    std::cerr << "holovolume: volume '" << options.Volume << "' not found."
              << (options.Volume == holovolume::DefaultVolume()
                     ? " Install it with: apt-get install mricron-data"
                     : "")
              << "\n";
    return 1;
  }

  vtkSmartPointer<vtkImageData> volumeData = holovolume::ReadVolume(options.Volume);
  if (!volumeData)
  {
    std::cerr << "holovolume: could not read a volume from '" << options.Volume << "'\n";
    return 1;
  }
  int dims[3];
  volumeData->GetDimensions(dims);
  double range[2];
  volumeData->GetScalarRange(range);
  std::cout << "Volume       " << options.Volume << " (" << dims[0] << "x" << dims[1] << "x"
            << dims[2] << ", scalars " << range[0] << "-" << range[1] << ")\n";

  vtkNew<vtkPathTracedVolumeMapper> mapper;
  mapper->SetInputData(volumeData);
  vtkNew<vtkEnvironmentMapReader> environmentReader;
  if (options.Environment != "uniform")
  {
    if (!holovolume::FileExists(options.Environment))
    {
      std::cerr << "holovolume: environment map '" << options.Environment << "' not found."
                << (options.Environment == holovolume::DefaultEnvironment()
                       ? " Install it with: apt-get install blender-data"
                       : " Use --environment uniform for a uniform sky.")
                << "\n";
      return 1;
    }
    environmentReader->SetFileName(options.Environment.c_str());
    environmentReader->Update();
    if (environmentReader->GetOutput()->GetNumberOfPoints() == 0)
    {
      std::cerr << "holovolume: could not read the environment map '" << options.Environment
                << "'\n";
      return 1;
    }
    mapper->SetEnvironmentMapConnection(environmentReader->GetOutputPort());
    int mapDims[3];
    environmentReader->GetOutput()->GetDimensions(mapDims);
    std::cout << "Environment  " << options.Environment << " (" << mapDims[0] << "x" << mapDims[1]
              << ")\n";
  }
  else
  {
    std::cout << "Environment  uniform, radiance 1\n";
  }
  vtkNew<vtkMatrix4x4> environmentToWorld;
  holovolume::EnvironmentToRASWorld(environmentToWorld, options.EnvironmentYaw);
  mapper->SetEnvironmentToWorldMatrix(environmentToWorld);
  mapper->SetEnvironmentIntensity(options.EnvironmentIntensity);
  mapper->SetEnvironmentVisible(options.ShowEnvironment);
  mapper->SetSamplesPerPixel(options.SamplesPerPixel);
  mapper->SetMaximumBounces(options.Bounces);
  mapper->SetSeed(options.Seed);
  mapper->SetExposure(options.Exposure);
  mapper->SetToneMapping(options.ToneMapping == "aces"
      ? vtkPathTracedVolumeMapper::TONE_MAPPING_ACES
      : vtkPathTracedVolumeMapper::TONE_MAPPING_CLAMP);

  vtkNew<vtkVolumeProperty> property;
  holovolume::ApplyHeadMRIPreset(property, range[1] > 0 ? range[1] : 255.0);
  vtkNew<vtkVolume> volume;
  volume->SetMapper(mapper);
  volume->SetProperty(property);

  vtkNew<vtkCamera> camera;
  holovolume::FrameHead(camera, volumeData, options.Azimuth);
  const double aspect = static_cast<double>(options.Width) / options.Height;
  vtkNew<vtkMatrix4x4> view[2];
  vtkNew<vtkMatrix4x4> projection[2];
  for (int eye = 0; eye < 2; ++eye)
  {
    holovolume::StereoEyeMatrices(camera, aspect,
      options.Stereo ? options.InterpupillaryDistance : 0.0, eye, view[eye], projection[eye]);
  }
  // The gradient-Phong model needs lights: a headlight-like key light from the camera side.
  vtkNew<vtkLightCollection> lights;
  vtkNew<vtkLight> keyLight;
  keyLight->SetLightTypeToSceneLight();
  keyLight->SetPosition(camera->GetPosition());
  keyLight->SetFocalPoint(camera->GetFocalPoint());
  keyLight->PositionalOff();
  lights->AddItem(keyLight);

  mkdir(options.Output.c_str(), 0755);
  std::cout << "Output       " << options.Output << "/ (" << options.Width << "x" << options.Height
            << " per eye, " << (options.Stereo ? "stereo" : "mono") << ", "
            << options.SamplesPerPixel << " spp x " << options.Frames << " frames)\n";

  ProgressState progress;
  vtkNew<vtkCallbackCommand> progressCallback;
  progressCallback->SetCallback(OnProgress);
  progressCallback->SetClientData(&progress);
  mapper->AddObserver(vtkCommand::ProgressEvent, progressCallback);

  for (const std::string& model : options.Models)
  {
    if (model == "path-traced")
      mapper->SetIlluminationModelToPathTraced();
    else if (model == "emission-absorption")
      mapper->SetIlluminationModelToEmissionAbsorption();
    else if (model == "gradient-phong")
      mapper->SetIlluminationModelToGradientPhong();
    else
      mapper->SetIlluminationModelToPrefilteredEnvironment();
    // Only the path tracer gains from progressive frames; the others are near-deterministic.
    progress.Label = model;
    progress.Frames = model == "path-traced" ? options.Frames : std::min(options.Frames, 4);
    const auto start = std::chrono::steady_clock::now();
    for (progress.Frame = 0; progress.Frame < progress.Frames; ++progress.Frame)
    {
      const int ok = options.Stereo
        ? mapper->RenderStereoFrame(volume, view[0], projection[0], view[1], projection[1],
            options.Width, options.Height, model == "gradient-phong" ? lights.Get() : nullptr)
        : mapper->RenderEye(volume, 0, view[0], projection[0], options.Width, options.Height,
            model == "gradient-phong" ? lights.Get() : nullptr);
      if (!ok)
      {
        std::cerr << "\nholovolume: rendering failed (see the message above)\n";
        return 1;
      }
    }
    const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (isatty(fileno(stderr)))
    {
      std::fprintf(stderr, "\n");
    }
    std::printf("  %-24s %d frames in %.2f s (%.0f ms per %s frame)\n", model.c_str(),
      progress.Frames, seconds, 1000.0 * seconds / progress.Frames,
      options.Stereo ? "stereo" : "mono");

    const std::string prefix = options.Output + "/" + model;
    if (options.Stereo)
    {
      auto left = DisplayImage(mapper, 0, options.Transparent);
      auto right = DisplayImage(mapper, 1, options.Transparent);
      WritePNG(left, prefix + "-left.png");
      WritePNG(right, prefix + "-right.png");
      vtkNew<vtkImageAppend> sideBySide;
      sideBySide->SetAppendAxis(0);
      sideBySide->AddInputData(left);
      sideBySide->AddInputData(right);
      sideBySide->Update();
      WritePNG(sideBySide->GetOutput(), prefix + "-stereo.png");
      std::cout << "               wrote " << prefix << "-{left,right,stereo}.png\n";
    }
    else
    {
      WritePNG(DisplayImage(mapper, 0, options.Transparent), prefix + ".png");
      std::cout << "               wrote " << prefix << ".png\n";
    }
    if (options.SaveBuffers)
    {
      for (int eye = 0; eye < (options.Stereo ? 2 : 1); ++eye)
      {
        vtkNew<vtkXMLImageDataWriter> writer;
        writer->SetInputData(mapper->GetEyeOutput(eye));
        const std::string path = prefix + (eye == 0 ? "-left" : "-right") + "-buffers.vti";
        writer->SetFileName(path.c_str());
        writer->Write();
        std::cout << "               wrote " << path << "\n";
      }
    }
  }
  return 0;
}
