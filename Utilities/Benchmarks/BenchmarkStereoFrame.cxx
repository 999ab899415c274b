// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// holovolume-benchmark: the cost of one HoloLens 2 stereo frame of the path tracer, measured
// side by side, in the same run, with VTK's own volume ray casters
// (vtkFixedPointVolumeRayCastMapper on the CPU, vtkOpenGLGPUVolumeRayCastMapper on whatever OpenGL
// there is) rendering the same data with the same transfer function from the same two eye views.
#include "vtkHoloVolumeScene.h"

#include "vtkCallbackCommand.h"
#include "vtkCamera.h"
#include "vtkCommand.h"
#include "vtkEnvironmentMapReader.h"
#include "vtkFixedPointVolumeRayCastMapper.h"
#include "vtkFloatArray.h"
#include "vtkGPUVolumeRayCastMapper.h"
#include "vtkImageData.h"
#include "vtkLight.h"
#include "vtkLightCollection.h"
#include "vtkMatrix4x4.h"
#include "vtkNIFTIImageReader.h"
#include "vtkNew.h"
#include "vtkPNGWriter.h"
#include "vtkPathTracedVolumeMapper.h"
#include "vtkPiecewiseFunction.h"
#include "vtkPointData.h"
#include "vtkRenderWindow.h"
#include "vtkRenderer.h"
#include "vtkSMPTools.h"
#include "vtkSmartPointer.h"
#include "vtkVolume.h"
#include "vtkVolumeProperty.h"
#include "vtkWindowToImageFilter.h"
#include "vtkXMLImageDataReader.h"

#include <X11/Xlib.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <numeric>
#include <sstream>
#include <string>
#include <sys/resource.h>
#include <sys/stat.h>
#include <thread>
#include <vector>

namespace
{
struct Options
{
  std::string Volume = holovolume::DefaultVolume();
  std::string Environment = holovolume::DefaultEnvironment();
  std::vector<std::string> Models = { "path-traced" };
  int Width = 1440; // HoloLens 2, per eye
  int Height = 936;
  int SamplesPerPixel = 2;
  int Frames = 5;
  int Threads = 0;
  // Secondary-ray roulette levels to time for the path-traced model; the first is the one
  // compared with the fixed-point mapper.
  std::vector<double> Roulette = { 0.5, 0.0 };
  int NoiseFrames = 8;
  double InterpupillaryDistance = 64.0;
  bool References = true;
  std::string SaveImages;
};

void PrintHelp()
{
  std::cout <<
    R"(Usage: holovolume-benchmark [options]

Times one stereo frame of HoloVolume's path tracer (vtkPathTracedVolumeMapper::RenderStereoFrame)
and, in the same run, VTK's vtkFixedPointVolumeRayCastMapper (shaded) and
vtkOpenGLGPUVolumeRayCastMapper rendering the same volume, transfer function and eye views.
The first frame of each mapper (classification, majorant grid, gradients, texture upload,
shader compilation) is reported on its own; the median and mean are over the frames after it.
After them one more frame is timed with every opacity point of the transfer function lowered
by 1 % (then put back): what a user who edits the transfer function waits for, the mapper's
reclassification included.

The VTK mappers need an X display; run headless as
  xvfb-run -a -s "-screen 0 1920x1080x24 -noreset" holovolume-benchmark
Without one their rows are skipped.

Data
      --volume FILE        NIfTI (.nii, .nii.gz) or VTK XML image (.vti) volume
                           [/usr/share/mricron/templates/ch2.nii.gz, package mricron-data]
      --environment FILE   HDR panorama (.exr, .hdr) lighting the path tracer, or 'uniform'
                           [/usr/share/blender/datafiles/studiolights/world/courtyard.exr,
                            package blender-data]

Rendering
      --width N            pixels per eye [1440, HoloLens 2]
      --height N           pixels per eye [936, HoloLens 2]
      --spp N              path-tracer samples per pixel per frame [2]
      --ipd MM             interpupillary distance in volume units (mm) [64]
      --model NAMES        HoloVolume illumination models to time, comma-separated:
                           path-traced, emission-absorption, gradient-phong,
                           prefiltered-environment, or all [path-traced]
      --roulette LEVELS    vtkPathTracedVolumeMapper::SecondaryRayRoulette values to time the
                           path-traced model with, comma-separated; the first is compared with
                           the fixed-point mapper, 0 traces every secondary ray [0.5,0]

Measurement
      --frames N           timed stereo frames per mapper, after the first [5]
      --noise-frames N     further path-traced frames whose pixel-wise spread gives the noise
                           of one frame, so faster settings can be weighed against noisier
                           ones; 0 skips it [8]
      --threads N          worker threads for every CPU renderer: vtkSMPTools for the path
                           tracer, vtkMultiThreader for the fixed-point ray caster and
                           LP_NUM_THREADS for Mesa llvmpipe (unless already set) [all cores]
      --no-reference       time only the HoloVolume models
      --save-images DIR    write each mapper's left and right eye as PNG into DIR, to check
                           that all mappers show the same views
  -h, --help               this text

Path-traced samples per second = 2 eyes x width x height x spp / seconds per stereo frame.
Noise of a path-traced frame: the pixel-wise variance of the left eye's linear luminance over
the noise frames (independent frames of the same view), averaged over the pixels the volume
covers fully, relative to their squared mean. Efficiency = 1 / (noise^2 x frame time), the
usual Monte-Carlo figure of merit, relative to the last roulette level's.
The VTK ray casters shoot one ray per pixel, so their rate is rays per second
(2 x width x height / seconds); ray-cast steps and path samples are not comparable units.
)";
}

bool ParseModels(const std::string& list, std::vector<std::string>& models)
{
  const std::vector<std::string> known = { "path-traced", "emission-absorption", "gradient-phong",
    "prefiltered-environment" };
  models.clear();
  std::stringstream stream(list);
  std::string name;
  while (std::getline(stream, name, ','))
  {
    if (name == "all")
    {
      models = known;
      return true;
    }
    if (std::find(known.begin(), known.end(), name) == known.end())
    {
      std::cerr << "holovolume-benchmark: unknown model '" << name
                << "'; use path-traced, emission-absorption, gradient-phong, "
                   "prefiltered-environment or all\n";
      return false;
    }
    models.push_back(name);
  }
  return !models.empty();
}

bool ParseArguments(int argc, char* argv[], Options& options)
{
  const char* program = "holovolume-benchmark";
  for (int i = 1; i < argc; ++i)
  {
    const std::string argument = argv[i];
    auto value = [&]() -> const char*
    {
      if (i + 1 >= argc)
      {
        std::cerr << "holovolume-benchmark: " << argument << " needs a value (see --help)\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (argument == "-h" || argument == "--help")
    {
      PrintHelp();
      std::exit(0);
    }
    else if (argument == "--volume")
      options.Volume = value();
    else if (argument == "--environment")
      options.Environment = value();
    else if (argument == "--width")
      options.Width = holovolume::IntegerOption(program, "--width", value(), 1, 16384);
    else if (argument == "--height")
      options.Height = holovolume::IntegerOption(program, "--height", value(), 1, 16384);
    else if (argument == "--spp")
      options.SamplesPerPixel = holovolume::IntegerOption(program, "--spp", value(), 1, 1 << 20);
    else if (argument == "--ipd")
      options.InterpupillaryDistance = std::atof(value());
    else if (argument == "--model")
    {
      if (!ParseModels(value(), options.Models))
      {
        return false;
      }
    }
    else if (argument == "--roulette")
    {
      options.Roulette.clear();
      std::stringstream stream(value());
      std::string level;
      while (std::getline(stream, level, ','))
      {
        char* end = nullptr;
        const double k = std::strtod(level.c_str(), &end);
        if (level.empty() || *end != '\0' || !(k >= 0.0))
        {
          std::cerr << "holovolume-benchmark: --roulette takes non-negative numbers separated "
                       "by commas, e.g. 0.5,0\n";
          return false;
        }
        options.Roulette.push_back(k);
      }
    }
    else if (argument == "--noise-frames")
      options.NoiseFrames =
        holovolume::IntegerOption(program, "--noise-frames", value(), 0, 100000);
    else if (argument == "--frames")
      options.Frames = holovolume::IntegerOption(program, "--frames", value(), 1, 100000);
    else if (argument == "--threads")
      options.Threads = holovolume::IntegerOption(program, "--threads", value(), 0, 1024);
    else if (argument == "--no-reference")
      options.References = false;
    else if (argument == "--save-images")
      options.SaveImages = value();
    else
    {
      std::cerr << "holovolume-benchmark: unknown option '" << argument << "' (see --help)\n";
      return false;
    }
  }
  if (options.Roulette.empty())
  {
    std::cerr << "holovolume-benchmark: --roulette needs a level\n";
    return false;
  }
  return true;
}

std::string BaseName(const std::string& path)
{
  const std::string::size_type slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

double Median(std::vector<double> values)
{
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

double Mean(const std::vector<double>& values)
{
  return std::accumulate(values.begin(), values.end(), 0.0) / values.size();
}

// User plus system CPU time of the whole process (all threads, llvmpipe's included).
double ProcessCPUSeconds()
{
  struct rusage usage;
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_utime.tv_sec + usage.ru_stime.tv_sec +
    1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

double MillisecondsSince(std::chrono::steady_clock::time_point start)
{
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
    .count();
}

// One image per eye reduced to a coverage mask (1 where the volume shows), to check after the
// timing that every mapper drew the same silhouette, i.e. really rendered the same views.
using Mask = std::vector<unsigned char>;

Mask CoverageMask(vtkImageData* image, int threshold)
{
  const int components = image->GetNumberOfScalarComponents();
  const vtkIdType pixels = image->GetNumberOfPoints();
  const unsigned char* data = static_cast<unsigned char*>(image->GetScalarPointer());
  Mask mask(pixels, 0);
  for (vtkIdType i = 0; i < pixels; ++i)
  {
    int level = 0;
    for (int c = 0; c < components; ++c)
    {
      level = std::max(level, static_cast<int>(data[components * i + c]));
    }
    mask[i] = level > threshold ? 1 : 0;
  }
  return mask;
}

double CoveredFraction(const Mask& mask)
{
  return mask.empty() ? 0.0 : std::accumulate(mask.begin(), mask.end(), 0.0) / mask.size();
}

// Intersection over union of two coverage masks; 1 for identical silhouettes.
double SilhouetteAgreement(const Mask& a, const Mask& b)
{
  if (a.size() != b.size())
  {
    return 0.0;
  }
  double intersection = 0.0, join = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
  {
    intersection += a[i] & b[i];
    join += a[i] | b[i];
  }
  return join > 0.0 ? intersection / join : 0.0;
}

void WritePNG(vtkImageData* image, const std::string& path)
{
  vtkNew<vtkPNGWriter> writer;
  writer->SetInputData(image);
  writer->SetFileName(path.c_str());
  writer->Write();
}

struct Result
{
  std::string Mapper;
  std::string Model; // the HoloVolume illumination model; empty for VTK's mappers
  bool Ran = false;
  std::string Note;          // why a row was skipped, or a caveat
  double FirstFrameMs = 0.0; // the one-off first stereo frame
  double TransferChangeFrameMs = -1.0; // the frame after an opacity change; < 0: not timed
  // The path tracer's scene preparation before its rays start (its StartEvent): on the first
  // frame loading the volume and classifying it, after the opacity change classifying it again.
  double FirstPrepareMs = -1.0;
  double TransferChangePrepareMs = -1.0;
  std::vector<double> FrameMs;
  double CPUSeconds = 0.0;   // process CPU time over the timed frames
  double WorkPerFrame = 0.0; // samples (path tracer) or rays (ray casters) per stereo frame
  const char* WorkUnit = "";
  double Roulette = -1.0;      // SecondaryRayRoulette of a path-traced row
  double RelativeNoise = -1.0; // RMS / mean luminance of one frame; < 0 when not measured
  Mask Masks[2];
};

// Times renderStereoFrame() after lowering every opacity point of the property by 1 %, which
// makes the mapper classify the volume again; the points are put back afterwards.
template <typename RenderStereoFrame>
double TimeAfterOpacityChange(vtkVolumeProperty* property, RenderStereoFrame renderStereoFrame)
{
  vtkPiecewiseFunction* opacity = property->GetScalarOpacity();
  std::vector<std::array<double, 4>> nodes(opacity->GetSize());
  for (int i = 0; i < opacity->GetSize(); ++i)
  {
    opacity->GetNodeValue(i, nodes[i].data());
    std::array<double, 4> lowered = nodes[i];
    lowered[1] *= 0.99;
    opacity->SetNodeValue(i, lowered.data());
  }
  const auto start = std::chrono::steady_clock::now();
  const bool rendered = renderStereoFrame();
  const double milliseconds = MillisecondsSince(start);
  for (int i = 0; i < opacity->GetSize(); ++i)
  {
    opacity->SetNodeValue(i, nodes[i].data());
  }
  return rendered ? milliseconds : -1.0;
}

// Notes when the path tracer starts its rays (StartEvent, after it has prepared the scene).
void NoteTime(vtkObject*, unsigned long, void* clientData, void*)
{
  *static_cast<std::chrono::steady_clock::time_point*>(clientData) =
    std::chrono::steady_clock::now();
}

// Counts the events a mapper fires when it actually casts rays, so a row can be rejected
// if a timed frame was a cached no-op.
void CountEvent(vtkObject*, unsigned long, void* clientData, void*)
{
  ++*static_cast<int*>(clientData);
}

// Keeps the first error a VTK object reports instead of printing it, so a reference mapper
// that cannot run here becomes a skipped row with its reason.
void KeepFirstError(vtkObject*, unsigned long, void* clientData, void* callData)
{
  auto* message = static_cast<std::string*>(clientData);
  if (message->empty() && callData)
  {
    *message = static_cast<const char*>(callData);
  }
}

bool XDisplayAvailable()
{
  const char* display = std::getenv("DISPLAY");
  if (!display || !*display)
  {
    return false;
  }
  // vtkXOpenGLRenderWindow aborts when it cannot connect, so probe the server first.
  Display* connection = XOpenDisplay(nullptr);
  if (!connection)
  {
    return false;
  }
  XCloseDisplay(connection);
  return true;
}

const char* ModelLabel(const std::string& model)
{
  if (model == "emission-absorption")
    return "EmissionAbsorption";
  if (model == "gradient-phong")
    return "GradientPhong";
  if (model == "prefiltered-environment")
    return "PrefilteredEnvironment";
  return "PathTraced";
}

// The noise of one frame: renders `frames` independent frames of the same view and returns the
// pixel-wise variance of the left eye's linear luminance, averaged over the pixels the volume
// covers in every frame, divided by their squared mean luminance (its square root: RMS / mean).
// Returns -1 if a frame fails or nothing is covered.
template <typename RenderFrame>
double MeasureRelativeNoise(vtkPathTracedVolumeMapper* mapper, int frames, RenderFrame render)
{
  std::vector<double> sum, sumOfSquares;
  std::vector<unsigned char> alwaysCovered;
  for (int frame = 0; frame < frames; ++frame)
  {
    if (!render())
    {
      return -1.0;
    }
    vtkFloatArray* radiance =
      vtkFloatArray::SafeDownCast(mapper->GetEyeOutput(0)->GetPointData()->GetArray("Radiance"));
    const vtkIdType count = radiance->GetNumberOfTuples();
    if (sum.empty())
    {
      sum.assign(count, 0.0);
      sumOfSquares.assign(count, 0.0);
      alwaysCovered.assign(count, 1);
    }
    const float* rgba = radiance->GetPointer(0);
    for (vtkIdType i = 0; i < count; ++i)
    {
      // Pixels partly covered carry the silhouette's coverage noise too: leave them out.
      alwaysCovered[i] = alwaysCovered[i] && rgba[4 * i + 3] >= 1.0f;
      const double y = 0.2126 * rgba[4 * i] + 0.7152 * rgba[4 * i + 1] + 0.0722 * rgba[4 * i + 2];
      sum[i] += y;
      sumOfSquares[i] += y * y;
    }
  }
  double meanVariance = 0.0, meanLuminance = 0.0;
  std::size_t pixels = 0;
  for (std::size_t i = 0; i < sum.size(); ++i)
  {
    if (!alwaysCovered[i])
    {
      continue;
    }
    const double mean = sum[i] / frames;
    meanVariance += (sumOfSquares[i] - frames * mean * mean) / (frames - 1);
    meanLuminance += mean;
    ++pixels;
  }
  if (pixels == 0 || frames < 2 || meanLuminance <= 0.0)
  {
    return -1.0;
  }
  meanVariance /= pixels;
  meanLuminance /= pixels;
  return std::sqrt(std::max(meanVariance, 0.0)) / meanLuminance;
}

Result TimePathTracer(vtkPathTracedVolumeMapper* mapper, vtkVolume* volume,
  const std::string& model, double roulette, vtkMatrix4x4* const* views,
  vtkMatrix4x4* const* projections, vtkLightCollection* lights, const Options& options)
{
  Result result;
  result.Mapper = std::string("vtkPathTracedVolumeMapper (") + ModelLabel(model) + ")";
  if (model == "path-traced")
  {
    std::ostringstream label;
    label << "vtkPathTracedVolumeMapper (PathTraced, roulette " << roulette << ")";
    result.Mapper = label.str();
    result.Roulette = roulette;
    mapper->SetSecondaryRayRoulette(roulette);
  }
  result.Model = model;
  result.WorkPerFrame = 2.0 * options.Width * options.Height * options.SamplesPerPixel;
  result.WorkUnit = "samples/s";
  if (model == "path-traced")
    mapper->SetIlluminationModelToPathTraced();
  else if (model == "emission-absorption")
    mapper->SetIlluminationModelToEmissionAbsorption();
  else if (model == "gradient-phong")
    mapper->SetIlluminationModelToGradientPhong();
  else
    mapper->SetIlluminationModelToPrefilteredEnvironment();
  // Only gradient-Phong uses the key light, as in the holovolume application.
  vtkLightCollection* modelLights = model == "gradient-phong" ? lights : nullptr;

  auto renderStereoFrame = [&]()
  {
    return mapper->RenderStereoFrame(volume, views[0], projections[0], views[1], projections[1],
      options.Width, options.Height, modelLights);
  };
  std::chrono::steady_clock::time_point raysStart;
  vtkNew<vtkCallbackCommand> noteRaysStart;
  noteRaysStart->SetCallback(NoteTime);
  noteRaysStart->SetClientData(&raysStart);
  const unsigned long startObserver = mapper->AddObserver(vtkCommand::StartEvent, noteRaysStart);
  const auto preparationMs = [&raysStart](std::chrono::steady_clock::time_point frameStart)
  { return std::chrono::duration<double, std::milli>(raysStart - frameStart).count(); };
  std::cerr << "  " << result.Mapper << ": first frame..." << std::flush;
  auto start = std::chrono::steady_clock::now();
  if (!renderStereoFrame())
  {
    std::cerr << "\n";
    result.Note = "RenderStereoFrame failed (see the error above)";
    mapper->RemoveObserver(startObserver);
    return result;
  }
  result.FirstFrameMs = MillisecondsSince(start);
  result.FirstPrepareMs = preparationMs(start);
  std::cerr << " " << static_cast<int>(result.FirstFrameMs) << " ms; timing " << options.Frames
            << " frames..." << std::flush;
  const double cpuStart = ProcessCPUSeconds();
  for (int frame = 0; frame < options.Frames; ++frame)
  {
    start = std::chrono::steady_clock::now();
    if (!renderStereoFrame())
    {
      std::cerr << "\n";
      result.Note = "RenderStereoFrame failed (see the error above)";
      mapper->RemoveObserver(startObserver);
      return result;
    }
    result.FrameMs.push_back(MillisecondsSince(start));
  }
  result.CPUSeconds = ProcessCPUSeconds() - cpuStart;
  result.TransferChangeFrameMs = TimeAfterOpacityChange(volume->GetProperty(),
    [&]()
    {
      start = std::chrono::steady_clock::now();
      return renderStereoFrame();
    });
  result.TransferChangePrepareMs = preparationMs(start);
  mapper->RemoveObserver(startObserver);
  std::cerr << " done\n";
  result.Ran = true;
  if (model == "path-traced" && options.NoiseFrames > 1)
  {
    std::cerr << "    noise over " << options.NoiseFrames << " frames..." << std::flush;
    result.RelativeNoise = MeasureRelativeNoise(mapper, options.NoiseFrames, renderStereoFrame);
    std::cerr << " done\n";
  }

  for (int eye = 0; eye < 2; ++eye)
  {
    vtkNew<vtkImageData> display;
    mapper->ComputeDisplayImage(eye, display);
    // Premultiplied RGBA: the alpha channel alone is the coverage.
    vtkNew<vtkImageData> alpha;
    alpha->SetDimensions(display->GetDimensions());
    alpha->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
    const unsigned char* rgba = static_cast<unsigned char*>(display->GetScalarPointer());
    unsigned char* a = static_cast<unsigned char*>(alpha->GetScalarPointer());
    for (vtkIdType i = 0; i < alpha->GetNumberOfPoints(); ++i)
    {
      a[i] = rgba[4 * i + 3];
    }
    result.Masks[eye] = CoverageMask(alpha, 8);
    if (!options.SaveImages.empty())
    {
      WritePNG(display, options.SaveImages + "/" + model + (eye == 0 ? "-left.png" : "-right.png"));
    }
  }
  return result;
}

// Times a VTK volume mapper in an off-screen render window of one eye's size, rendering the
// left and then the right eye camera per stereo frame.
Result TimeWindowMapper(const std::string& label, const std::string& fileTag,
  vtkVolumeMapper* mapper, vtkImageData* volumeData, vtkVolumeProperty* property,
  vtkCamera* const* eyeCameras, const Options& options)
{
  Result result;
  result.Mapper = label;
  result.WorkPerFrame = 2.0 * options.Width * options.Height;
  result.WorkUnit = "rays/s";

  std::string error;
  vtkNew<vtkCallbackCommand> errorCallback;
  errorCallback->SetCallback(KeepFirstError);
  errorCallback->SetClientData(&error);

  mapper->SetInputData(volumeData);
  mapper->AddObserver(vtkCommand::ErrorEvent, errorCallback);
  vtkNew<vtkVolume> volume;
  volume->SetMapper(mapper);
  volume->SetProperty(property);
  vtkNew<vtkRenderer> renderer;
  renderer->AddVolume(volume);
  renderer->SetBackground(0.0, 0.0, 0.0);
  vtkNew<vtkRenderWindow> window;
  window->AddObserver(vtkCommand::ErrorEvent, errorCallback);
  window->SetOffScreenRendering(1);
  window->SetMultiSamples(0);
  window->SetSize(options.Width, options.Height);
  window->AddRenderer(renderer);
  // Window and context creation are not the mapper's cost: do them before the first frame.
  window->Start();
  if (!error.empty())
  {
    result.Note = "no OpenGL render window: " + error;
    return result;
  }
  if (auto* gpuMapper = vtkGPUVolumeRayCastMapper::SafeDownCast(mapper))
  {
    if (!gpuMapper->IsRenderSupported(window, property))
    {
      result.Note = "IsRenderSupported() says no on this OpenGL";
      return result;
    }
  }

  int rayCasts = 0;
  vtkNew<vtkCallbackCommand> countCallback;
  countCallback->SetCallback(CountEvent);
  countCallback->SetClientData(&rayCasts);
  mapper->AddObserver(vtkCommand::VolumeMapperRenderEndEvent, countCallback);

  auto renderEye = [&](int eye)
  {
    // A new camera and a Modified() one: nothing in the pipeline may treat the frame as
    // unchanged (the per-frame event count below checks that it was not).
    eyeCameras[eye]->Modified();
    renderer->SetActiveCamera(eyeCameras[eye]);
    window->Render();
  };
  auto renderStereoFrame = [&]()
  {
    renderEye(0);
    renderEye(1);
    // OpenGL may still be drawing when Render() returns.
    window->WaitForCompletion();
  };

  std::cerr << "  " << label << ": first frame..." << std::flush;
  auto start = std::chrono::steady_clock::now();
  renderStereoFrame();
  result.FirstFrameMs = MillisecondsSince(start);
  if (!error.empty())
  {
    std::cerr << "\n";
    result.Note = "failed: " + error;
    return result;
  }
  std::cerr << " " << static_cast<int>(result.FirstFrameMs) << " ms; timing " << options.Frames
            << " frames..." << std::flush;
  rayCasts = 0;
  const double cpuStart = ProcessCPUSeconds();
  for (int frame = 0; frame < options.Frames; ++frame)
  {
    start = std::chrono::steady_clock::now();
    renderStereoFrame();
    result.FrameMs.push_back(MillisecondsSince(start));
  }
  result.CPUSeconds = ProcessCPUSeconds() - cpuStart;
  std::cerr << " done\n";
  if (!error.empty())
  {
    result.Note = "failed: " + error;
    return result;
  }
  if (rayCasts != 2 * options.Frames)
  {
    std::ostringstream note;
    note << "mapper cast rays for " << rayCasts << " of " << 2 * options.Frames
         << " timed eye images; timing rejected";
    result.Note = note.str();
    return result;
  }
  result.TransferChangeFrameMs = TimeAfterOpacityChange(property,
    [&]()
    {
      renderStereoFrame();
      return error.empty();
    });
  result.Ran = true;

  for (int eye = 0; eye < 2; ++eye)
  {
    renderer->SetActiveCamera(eyeCameras[eye]);
    vtkNew<vtkWindowToImageFilter> grab;
    grab->SetInput(window);
    grab->SetInputBufferTypeToRGB();
    grab->ReadFrontBufferOff();
    grab->ShouldRerenderOn();
    grab->Update();
    result.Masks[eye] = CoverageMask(grab->GetOutput(), 8);
    if (!options.SaveImages.empty())
    {
      WritePNG(grab->GetOutput(),
        options.SaveImages + "/" + fileTag + (eye == 0 ? "-left.png" : "-right.png"));
    }
  }
  if (CoveredFraction(result.Masks[0]) == 0.0 && CoveredFraction(result.Masks[1]) == 0.0)
  {
    result.Ran = false;
    result.Note = "rendered empty images; timing rejected";
  }
  return result;
}
}

int main(int argc, char* argv[])
{
  Options options;
  if (!ParseArguments(argc, argv, options))
  {
    return 2;
  }

  // One thread count for every CPU renderer, so the comparison is per core-second.
  const int threads =
    options.Threads > 0 ? options.Threads : std::max(1u, std::thread::hardware_concurrency());
  vtkSMPTools::Initialize(threads);
  // Mesa reads LP_NUM_THREADS when it creates the llvmpipe screen, i.e. at the first window.
  setenv("LP_NUM_THREADS", std::to_string(threads).c_str(), 0);

  if (!holovolume::FileExists(options.Volume))
  {
    std::cerr << "holovolume-benchmark: volume '" << options.Volume << "' not found."
              << (options.Volume == holovolume::DefaultVolume()
                     ? " Install it with: apt-get install mricron-data"
                     : "")
              << "\n";
    return 1;
  }
  if (options.Environment != "uniform" && !holovolume::FileExists(options.Environment))
  {
    std::cerr << "holovolume-benchmark: environment map '" << options.Environment << "' not found."
              << (options.Environment == holovolume::DefaultEnvironment()
                     ? " Install it with: apt-get install blender-data"
                     : " Use --environment uniform for a uniform sky.")
              << "\n";
    return 1;
  }
  if (!options.SaveImages.empty())
  {
    mkdir(options.SaveImages.c_str(), 0755);
  }

  vtkSmartPointer<vtkImageData> volumeData = holovolume::ReadVolume(options.Volume);
  if (!volumeData)
  {
    std::cerr << "holovolume-benchmark: could not read a volume from '" << options.Volume << "'\n";
    return 1;
  }
  int dims[3];
  volumeData->GetDimensions(dims);
  double range[2];
  volumeData->GetScalarRange(range);

  // One property for all mappers: the head-MRI preset (shading on) of the application.
  vtkNew<vtkVolumeProperty> property;
  holovolume::ApplyHeadMRIPreset(property, range[1] > 0 ? range[1] : 255.0);

  // The path tracer and its environment.
  vtkNew<vtkPathTracedVolumeMapper> pathTracer;
  pathTracer->SetInputData(volumeData);
  vtkNew<vtkEnvironmentMapReader> environmentReader;
  std::string environmentDescription = "uniform";
  if (options.Environment != "uniform")
  {
    environmentReader->SetFileName(options.Environment.c_str());
    environmentReader->Update();
    if (environmentReader->GetOutput()->GetNumberOfPoints() == 0)
    {
      std::cerr << "holovolume-benchmark: could not read the environment map '"
                << options.Environment << "'\n";
      return 1;
    }
    pathTracer->SetEnvironmentMapConnection(environmentReader->GetOutputPort());
    int mapDims[3];
    environmentReader->GetOutput()->GetDimensions(mapDims);
    environmentDescription = BaseName(options.Environment) + " " + std::to_string(mapDims[0]) +
      "x" + std::to_string(mapDims[1]);
  }
  vtkNew<vtkMatrix4x4> environmentToWorld;
  holovolume::EnvironmentToRASWorld(environmentToWorld, 0.0);
  pathTracer->SetEnvironmentToWorldMatrix(environmentToWorld);
  pathTracer->SetSamplesPerPixel(options.SamplesPerPixel);
  // A headset's pose changes every frame, so no frame may reuse the samples of earlier ones:
  // time the cost of a fresh frame.
  pathTracer->ProgressiveAccumulationOff();
  vtkNew<vtkVolume> pathTracedVolume;
  pathTracedVolume->SetMapper(pathTracer);
  pathTracedVolume->SetProperty(property);

  // The two eyes: matrices for the path tracer, equivalent cameras for the VTK mappers.
  vtkNew<vtkCamera> camera;
  holovolume::FrameHead(camera, volumeData);
  const double aspect = static_cast<double>(options.Width) / options.Height;
  vtkNew<vtkMatrix4x4> viewMatrices[2];
  vtkNew<vtkMatrix4x4> projectionMatrices[2];
  vtkNew<vtkCamera> eyeCameras[2];
  for (int eye = 0; eye < 2; ++eye)
  {
    holovolume::StereoEyeMatrices(camera, aspect, options.InterpupillaryDistance, eye,
      viewMatrices[eye], projectionMatrices[eye]);
    holovolume::StereoEyeCamera(
      camera, aspect, options.InterpupillaryDistance, eye, eyeCameras[eye]);
  }
  vtkMatrix4x4* views[2] = { viewMatrices[0], viewMatrices[1] };
  vtkMatrix4x4* projections[2] = { projectionMatrices[0], projectionMatrices[1] };
  vtkCamera* cameras[2] = { eyeCameras[0], eyeCameras[1] };

  // Key light for the gradient-Phong model, as in the holovolume application.
  vtkNew<vtkLightCollection> lights;
  vtkNew<vtkLight> keyLight;
  keyLight->SetLightTypeToSceneLight();
  keyLight->SetPosition(camera->GetPosition());
  keyLight->SetFocalPoint(camera->GetFocalPoint());
  keyLight->PositionalOff();
  lights->AddItem(keyLight);

  std::ostringstream header;
  header << "HoloVolume benchmark: " << BaseName(options.Volume) << " " << dims[0] << "x" << dims[1]
         << "x" << dims[2] << ", " << options.Width << "x" << options.Height << " per eye, stereo, "
         << options.SamplesPerPixel << " spp, threads=" << threads;
  std::cerr << header.str() << "\n";

  std::vector<Result> results;
  for (const std::string& model : options.Models)
  {
    const std::vector<double> levels =
      model == "path-traced" ? options.Roulette : std::vector<double>{ 0.0 };
    for (double roulette : levels)
    {
      results.push_back(TimePathTracer(
        pathTracer, pathTracedVolume, model, roulette, views, projections, lights, options));
    }
  }

  bool haveDisplay = false;
  if (options.References)
  {
    haveDisplay = XDisplayAvailable();
    if (!haveDisplay)
    {
      const char* display = std::getenv("DISPLAY");
      const std::string reason = display && *display
        ? std::string("cannot open X display '") + display + "'"
        : std::string("no X display (DISPLAY unset)");
      for (const char* label :
        { "vtkFixedPointVolumeRayCastMapper (shaded)", "vtkOpenGLGPUVolumeRayCastMapper" })
      {
        Result skipped;
        skipped.Mapper = label;
        skipped.Note =
          "skipped: " + reason + "; run under xvfb-run -a -s \"-screen 0 1920x1080x24 -noreset\"";
        results.push_back(skipped);
      }
    }
  }
  std::string rendererName;
  if (haveDisplay)
  {
    // Full-quality rendering at a fixed step of one voxel (the opacity unit distance): the
    // automatic adjustment would lower the resolution to meet a frame rate, different per run.
    vtkNew<vtkFixedPointVolumeRayCastMapper> fixedPoint;
    fixedPoint->AutoAdjustSampleDistancesOff();
    fixedPoint->SetSampleDistance(1.0);
    fixedPoint->SetImageSampleDistance(1.0);
    fixedPoint->SetNumberOfThreads(threads);
    results.push_back(TimeWindowMapper("vtkFixedPointVolumeRayCastMapper (shaded)", "fixed-point",
      fixedPoint, volumeData, property, cameras, options));
    if (fixedPoint->GetNumberOfThreads() != threads)
    {
      results.back().Note =
        "ran with " + std::to_string(fixedPoint->GetNumberOfThreads()) + " threads";
    }

    // vtkGPUVolumeRayCastMapper::New() gives the OpenGL implementation through the factory.
    vtkSmartPointer<vtkGPUVolumeRayCastMapper> gpu =
      vtkSmartPointer<vtkGPUVolumeRayCastMapper>::New();
    gpu->AutoAdjustSampleDistancesOff();
    gpu->LockSampleDistanceToInputSpacingOff();
    gpu->SetSampleDistance(1.0);
    gpu->SetImageSampleDistance(1.0);
    {
      // Ask the OpenGL driver's name for the row label (llvmpipe is Mesa's software rasterizer).
      vtkNew<vtkRenderWindow> probe;
      probe->SetOffScreenRendering(1);
      probe->SetSize(16, 16);
      probe->Start();
      const std::string capabilities =
        probe->ReportCapabilities() ? probe->ReportCapabilities() : "";
      const std::string key = "OpenGL renderer string:";
      const std::string::size_type at = capabilities.find(key);
      if (at != std::string::npos)
      {
        const std::string::size_type begin = capabilities.find_first_not_of(' ', at + key.size());
        rendererName = capabilities.substr(begin, capabilities.find('\n', begin) - begin);
      }
    }
    const bool software = rendererName.find("llvmpipe") != std::string::npos;
    const std::string label = std::string(gpu->GetClassName()) +
      (software                  ? " (llvmpipe)"
          : rendererName.empty() ? ""
                                 : " (GPU)");
    results.push_back(TimeWindowMapper(label, "gpu", gpu, volumeData, property, cameras, options));
  }

  // The table.
  std::printf("\n%s\n", header.str().c_str());
  std::printf(
    "environment %s; SMP backend %s; fixed-point and GPU ray casters: shaded, step 1 voxel, "
    "full image resolution\n",
    environmentDescription.c_str(), vtkSMPTools::GetBackend());
  if (!rendererName.empty())
  {
    std::printf("OpenGL renderer: %s (LP_NUM_THREADS=%s)\n", rendererName.c_str(),
      std::getenv("LP_NUM_THREADS"));
  }
  std::printf(
    "timed frames per mapper: %d after the first; wall-clock, std::chrono::steady_clock\n\n",
    options.Frames);
  std::printf("%-56s %12s %24s %10s %20s %18s\n", "mapper", "first frame", "median ms/stereo frame",
    "mean", "rays or samples/s", "after TF change");
  const Result* pathTraced = nullptr;
  const Result* fixedPoint = nullptr;
  for (const Result& result : results)
  {
    if (!result.Ran)
    {
      std::printf("%-56s %s\n", result.Mapper.c_str(), result.Note.c_str());
      continue;
    }
    const double median = Median(result.FrameMs);
    char rate[64];
    std::snprintf(
      rate, sizeof(rate), "%.3g %s", result.WorkPerFrame / (median / 1000.0), result.WorkUnit);
    char first[32];
    std::snprintf(first, sizeof(first), "%.0f ms", result.FirstFrameMs);
    char transferChange[32] = "failed";
    if (result.TransferChangeFrameMs >= 0.0)
    {
      std::snprintf(
        transferChange, sizeof(transferChange), "%.1f ms", result.TransferChangeFrameMs);
    }
    std::printf("%-56s %12s %24.1f %10.1f %20s %18s\n", result.Mapper.c_str(), first, median,
      Mean(result.FrameMs), rate, transferChange);
    if (!result.Note.empty())
    {
      std::printf("%-56s (%s)\n", "", result.Note.c_str());
    }
    // The first path-traced row when timed, otherwise the first HoloVolume model's.
    if (!result.Model.empty() &&
      (!pathTraced || (result.Model == "path-traced" && pathTraced->Model != "path-traced")))
    {
      pathTraced = &result;
    }
    if (result.Mapper.rfind("vtkFixedPointVolumeRayCastMapper", 0) == 0)
    {
      fixedPoint = &result;
    }
  }
  if (pathTraced && fixedPoint)
  {
    const double ratio = Median(pathTraced->FrameMs) / Median(fixedPoint->FrameMs);
    std::printf("ratio %s / fixed-point: %.2f (target <= 3: %s)\n", pathTraced->Model.c_str(),
      ratio, ratio <= 3.0 ? "met" : "NOT met");
  }
  else
  {
    std::printf("ratio path-traced / fixed-point: not available (fixed-point row missing)\n");
  }
  std::printf("\nthe path tracer's preparation before its rays start, ms (first frame: loading "
              "and classifying the volume; after the opacity change: classifying it again)\n");
  for (const Result& result : results)
  {
    if (result.Ran && result.FirstPrepareMs >= 0.0)
    {
      std::printf("  %-56s first frame %7.1f   after TF change %7.1f\n", result.Mapper.c_str(),
        result.FirstPrepareMs, result.TransferChangePrepareMs);
    }
  }

  // Roulette trades noise for time: weigh them together.
  const Result* noiseReference = nullptr;
  for (const Result& result : results)
  {
    if (result.Ran && result.RelativeNoise > 0.0)
    {
      noiseReference = &result;
    }
  }
  if (noiseReference)
  {
    std::printf("\nnoise of one path-traced frame over %d frames (left eye, pixels fully covered; "
                "efficiency = 1 / (noise^2 x time), relative to roulette %g):\n",
      options.NoiseFrames, noiseReference->Roulette);
    const double referenceMerit = 1.0 /
      (noiseReference->RelativeNoise * noiseReference->RelativeNoise *
        Median(noiseReference->FrameMs));
    for (const Result& result : results)
    {
      if (result.Ran && result.RelativeNoise > 0.0)
      {
        const double merit =
          1.0 / (result.RelativeNoise * result.RelativeNoise * Median(result.FrameMs));
        std::printf("  %-56s RMS/mean %.4f   efficiency %.2f\n", result.Mapper.c_str(),
          result.RelativeNoise, merit / referenceMerit);
      }
    }
  }

  // Wall-clock times are only comparable if every mapper had the cores to itself: show how busy
  // the process kept them, so a run disturbed by other load can be recognised and repeated.
  std::printf("\nCPU use over the timed frames (process CPU time / wall time / %d thread%s):\n",
    threads, threads == 1 ? "" : "s");
  bool disturbed = false;
  for (const Result& result : results)
  {
    if (!result.Ran)
    {
      continue;
    }
    const double wallSeconds =
      std::accumulate(result.FrameMs.begin(), result.FrameMs.end(), 0.0) / 1000.0;
    const double use = result.CPUSeconds / (wallSeconds * threads);
    std::printf("  %-56s %5.0f%%\n", result.Mapper.c_str(), 100.0 * use);
    // The path tracer is parallel throughout, so low use there means competing processes.
    disturbed = disturbed || (!result.Model.empty() && use < 0.8);
  }
  if (disturbed)
  {
    std::printf(
      "  note: the path tracer used under 80%% of its threads; other processes probably competed "
      "for the cores, so rerun on a quiet machine\n");
  }

  // The views check: every mapper's silhouettes against the first HoloVolume row's.
  if (!results.empty() && results.front().Ran)
  {
    const Result& reference = results.front();
    std::printf("\nsame-view check (coverage left/right, silhouette IoU with %s):\n",
      reference.Mapper.c_str());
    for (const Result& result : results)
    {
      if (!result.Ran)
      {
        continue;
      }
      std::printf("  %-56s %5.1f%% / %5.1f%%   IoU %.3f / %.3f\n", result.Mapper.c_str(),
        100.0 * CoveredFraction(result.Masks[0]), 100.0 * CoveredFraction(result.Masks[1]),
        SilhouetteAgreement(reference.Masks[0], result.Masks[0]),
        SilhouetteAgreement(reference.Masks[1], result.Masks[1]));
    }
  }
  return 0;
}
