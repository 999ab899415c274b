// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// holovolume: path-traced stereo renders of a CT/MRI volume under an HDR environment,
// written to PNG (and optionally the HDR/auxiliary buffers to .vti). The environment is an HDR
// panorama file (still mode) or the live radiance map of a 360-degree camera (live mode,
// --camera: vtkPanoramaVideoSource -> vtkDualFisheyeToEquirectangular ->
// vtkEnvironmentSyncedLight -> the mapper). With --denoise every frame is a fresh 2-spp render
// denoised by vtkStereoSpatioTemporalDenoiser, as on the headset; --serve streams to one.
#include "vtkHoloVolumeScene.h"
#include "vtkHoloLensRemotingOutput.h"
#include "vtkStereoSpatioTemporalDenoiser.h"

#include "vtkCallbackCommand.h"
#include "vtkCommand.h"
#include "vtkDataArray.h"
#include "vtkDualFisheyeToEquirectangular.h"
#include "vtkEnvironmentMapReader.h"
#include "vtkEnvironmentSyncedLight.h"
#include "vtkExecutive.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkImageAppend.h"
#include "vtkImageData.h"
#include "vtkLight.h"
#include "vtkLightCollection.h"
#include "vtkNew.h"
#include "vtkPNGWriter.h"
#include "vtkPanoramaVideoSource.h"
#include "vtkPathTracedVolumeMapper.h"
#include "vtkPointData.h"
#include "vtkPolyData.h"
#include "vtkSMPTools.h"
#include "vtkTransform.h"
#include "vtkUnsignedCharArray.h"
#include "vtkVolume.h"
#include "vtkXMLImageDataWriter.h"

#include "hv/lighting/CameraResponse.h"
#include "hv/lighting/FisheyeCalibration.h"
#include "hv/lighting/IlluminationDifference.h"
#include "hv/lighting/PanoramaFrameGrabber.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <iostream>
#include <limits>
#include <memory>
#include <string>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

namespace
{
// Mean radiance that --environment-intensity auto gives the first radiance map of a camera:
// about that of the CC0 HDR panoramas of blender-data (0.1-1.1, median 0.5, as stored).
constexpr double AutoMeanLuminance = 0.5;

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
  // Live mode: scale the first radiance map to a mean luminance of AutoMeanLuminance.
  bool AutoEnvironmentIntensity = true;
  double Azimuth = 35.0;
  unsigned int Seed = 0;
  bool SaveBuffers = false;
  bool Transparent = false;
  bool ShowEnvironment = false;
  int Threads = 0;
  // Live mode (--camera): the environment is the radiance map of a 360-degree camera.
  std::string Camera;
  std::string Calibration = "ricoh-theta";
  int CameraFrames = 30;
  bool CameraPacing = true;
  bool CameraEveryFrame = false;
  bool CameraLoop = false;
  double CameraWait = 0.0;
  double ProxyRadius = 2500.0;
  std::string HeadsetPosition = "viewer";
  // --camera-mount: the camera's position on the headset (volume units, the headset's x right,
  // y up, z back) and its yaw, pitch and roll against the gaze (degrees).
  double CameraMount[6] = { 0.0, 0.0, 0.0, 0.0, 0.0, 0.0 };
  double RelightThreshold = 0.05;
  bool SaveEnvironment = false;
  // --denoise: fresh 2-spp frames through the stereo denoiser instead of accumulation.
  bool DenoiseFrames = false;
  bool SaveFrames = false;
  // Serve mode (--serve): stream to a WebXR player instead of writing images.
  bool Serve = false;
  int Port = 8080;
  std::string Listen = "127.0.0.1";
  bool AllowRemote = false;
  std::string Token;
  std::string Certificate;
  std::string PrivateKey;
  std::string Codec = "jpeg";
  int EyeWidth = 1440;
  int EyeHeight = 936;
  bool Denoise = true;
  double ServeSeconds = 0.0;
  int ServeFrames = 0;
  std::string WebRoot;
};

void PrintHelp()
{
  std::cout <<
    R"(Usage: holovolume [options]

Renders a CT or MRI volume with HoloVolume's Monte-Carlo path tracer, lit by an HDR
environment map, for both eyes of a headset, and writes PNG images. The environment is an
HDR panorama file, or, in live mode (--camera), the light of the real room filmed by a
360-degree camera, re-estimated for every camera frame.

Defaults use real data from Debian packages: the ch2 head MRI (mricron-data) and the
'courtyard' HDR panorama (blender-data).

Input
  -v, --volume FILE          NIfTI (.nii, .nii.gz) or VTK XML image (.vti) volume
                             [/usr/share/mricron/templates/ch2.nii.gz]
  -e, --environment FILE     HDR panorama (.exr, .hdr), twice as wide as high, or
                             'uniform' for a uniform white sky; not used with --camera
                             [/usr/share/blender/datafiles/studiolights/world/courtyard.exr]
      --environment-yaw DEG  turn the panorama (or the camera) about the head's up axis [0]
      --environment-intensity X  scale the environment's radiance; 'auto' (live mode
                             only) scales the first radiance map of the camera to a mean
                             radiance of 0.5, that of typical HDR panoramas [1; live: auto]

Live lighting from a 360-degree camera (Documentation/LiveLighting.md)
      --camera SOURCE        the camera: a video file (.mp4, H.264 ...), /dev/videoN or a
                             device number, a stream URL (rtsp://, udp://, http://), an
                             image, or numbered images (frames/theta_%04d.png). Without a
                             camera, holovolume-simulate-camera films an HDR panorama.
      --calibration NAME     the camera's lenses: a preset (ricoh-theta, insta360-one-x),
                             a calibration JSON file (Documentation/FisheyeCalibration.md),
                             or 'equirectangular' for frames that are already panoramas
                             (LDR images or video; an EXR/HDR is used as HDR) [ricoh-theta]
      --camera-frames N      frames to render; each takes the newest camera frame [30]
      --camera-no-pacing     files: decode as fast as possible (frames are skipped while
                             rendering) instead of at the file's frame rate, as a camera
                             would deliver them
      --camera-every-frame   files: take the frames one after the other, none skipped
                             however long a frame renders (a recording rendered
                             offline; results that do not depend on the machine's load)
      --camera-loop          files: start again at the end
      --camera-wait S        before each frame, wait up to S seconds for a camera frame
                             newer than the last (to follow a recording frame by frame
                             when rendering is faster than the camera); 0: never wait,
                             render again with the same frame if none came [0]
      --proxy-radius MM      radius of the room around the camera, in the volume's units
                             (millimetres for NIfTI): lights are re-projected from the
                             camera to the volume's centre through this sphere [2500]
      --headset-position P   where the headset, and so the camera, is, in the volume's
                             coordinates: 'viewer' (between the rendered eyes), 'center'
                             (the volume's centre: no re-projection), 'origin', or X,Y,Z;
                             it is upright, facing the centre of a still-mode panorama
                             (turned by --environment-yaw) [viewer]
      --camera-mount X,Y,Z[,YAW[,PITCH[,ROLL]]]
                             how the camera sits on the headset: its lens centre X right,
                             Y up and Z back from the headset's origin (between the eyes),
                             in volume units, and its front lens turned YAW degrees to the
                             left of the gaze, PITCH up, ROLL counter-clockwise as the
                             wearer sees it; e.g. 0,120,40 for a camera on the headband,
                             12 cm above the eyes [0,0,0: at the eyes, along the gaze]
      --relight-threshold T  the radiance map in use is replaced, and the progressive
                             accumulation restarts, when the newest map differs from it by
                             an illumination difference T at least this (0: every new
                             camera frame) [0.05]
      --save-environment     also write the radiance map in use (tone-mapped) and the
                             stitched camera panorama as PNG

Rendering
  -m, --model NAME           path-traced, emission-absorption, gradient-phong,
                             prefiltered-environment, or all (one image set each;
                             live mode renders one model) [path-traced]
      --width N, --height N  pixels per eye [720 x 468; HoloLens 2 is 1440 x 936]
      --spp N                samples per pixel per frame [2]
      --frames N             frames accumulated progressively (not live) [32]
      --denoise              as on the headset: every frame a fresh render, denoised
                             by vtkStereoSpatioTemporalDenoiser with the frames before
                             and the other eye, instead of accumulated. Live mode: a new
                             radiance map relights the denoiser's history by its
                             illumination difference T, and each frame's line gives the
                             denoiser's time, history and mean radiance raw and denoised
      --bounces N            scatter events per path; 1 = single scattering [1]
      --mono                 one centred view instead of a stereo pair
      --ipd MM               interpupillary distance in volume units (mm) [64]
      --azimuth DEG          camera azimuth around the head (0 = face on) [35]
      --seed N               random seed, 0 to 2147483647 [0]
      --threads N            worker threads; 0 = all cores [0]

Streaming to a headset (Documentation/Remoting.md)
      --serve                serve the WebXR player and stream both eyes to it, rendered
                             for the headset's own pose (HoloLens 2 browser, any WebXR
                             headset, or side-by-side stereo in a desktop browser); prints
                             the URL to open, with its access token
      --port N               HTTP(S)/WebSocket port; 0 picks a free one [8080]
      --listen ADDRESS       address to listen on [127.0.0.1]; anything else needs
      --allow-remote         (a real headset on the LAN needs both, and TLS:)
      --certificate FILE     PEM certificate (chain) for HTTPS/WSS
      --private-key FILE     its PEM private key
      --token TOKEN          access token (16+ characters) [random, printed at start]
      --codec NAME           jpeg or h264 (clients without WebCodecs get JPEG) [jpeg]
      --eye-size WxH         pixels per eye [1440x936, the HoloLens 2's]
      --no-denoiser          stream the raw 2-spp frames
      --serve-seconds S      stop after S seconds [run until Ctrl-C]
      --serve-frames N       stop after N frames
      --camera SOURCE        light the volume with a 360-degree camera on the headset
                             (see Live lighting above; its pose is the viewer's head
                             pose) instead of an HDR panorama file
      --web-root DIR         serve the player from DIR [the module's web/ folder]

Output
  -o, --output DIR           output folder [holovolume-output]
      --save-frames          also write every frame's image (side by side for stereo)
                             as DIR/frames/<name>-NNNN.png, with --denoise the raw and
                             the denoised one (<name>-denoised-NNNN.png), for a video:
                             ffmpeg -i DIR/frames/live-path-traced-denoised-%04d.png
      --exposure STOPS       display exposure [0]
      --tone-mapping NAME    aces or clamp [aces]
      --transparent          keep the alpha channel instead of a dark background
      --show-environment     draw the environment behind the volume
      --save-buffers         also write each eye's HDR radiance and auxiliary buffers
                             (first-scatter position, depth, albedo, normal) as .vti,
                             and in live mode the radiance map as live-environment.vti
  -h, --help                 this text

Writes <model>-left.png, <model>-right.png and <model>-stereo.png (side by side) for
a stereo pair, <model>.png for --mono; with --denoise these are the last raw frame and
<model>-denoised-left.png and so on the denoised one. Live mode writes the last frame as
live-<model>-left.png and so on, plus live-environment.png and live-camera-panorama.png
with --save-environment, and prints per frame: the camera frame, the illumination
difference T, the number of detected lights, and the time of the lighting chain and of
the render.
)";
}

// --headset-position: where the 360-degree camera is, in the volume's coordinates.
bool ParseHeadsetPosition(
  const std::string& text, vtkCamera* camera, const double volumeCenter[3], double position[3])
{
  if (text == "center")
  {
    std::copy(volumeCenter, volumeCenter + 3, position);
    return true;
  }
  if (text == "viewer")
  {
    camera->GetPosition(position);
    return true;
  }
  if (text == "origin")
  {
    position[0] = position[1] = position[2] = 0.0;
    return true;
  }
  char end = 0;
  return std::sscanf(
           text.c_str(), "%lf,%lf,%lf%c", &position[0], &position[1], &position[2], &end) == 3 &&
    std::isfinite(position[0]) && std::isfinite(position[1]) && std::isfinite(position[2]);
}

// --camera-mount: three to six comma-separated finite numbers (the offset; yaw, pitch, roll, 0
// where left out).
bool ParseCameraMount(const std::string& text, double mount[6])
{
  std::vector<double> values;
  std::size_t start = 0;
  while (start <= text.size())
  {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string field = text.substr(start, comma - start);
    char* end = nullptr;
    const double value = std::strtod(field.c_str(), &end);
    if (field.empty() || *end != '\0' || !std::isfinite(value))
    {
      return false;
    }
    values.push_back(value);
    start = comma + 1;
  }
  if (values.size() < 3 || values.size() > 6)
  {
    return false;
  }
  std::fill(mount, mount + 6, 0.0);
  std::copy(values.begin(), values.end(), mount);
  return true;
}

// headsetFromCamera for --camera-mount: the offset, then yaw about the headset's up axis
// (positive turns the front lens, -Z, towards -X, the wearer's left), pitch about the camera's
// x axis (positive up) and roll about its optical axis.
void CameraMountMatrix(const double mount[6], vtkMatrix4x4* headsetFromCamera)
{
  vtkNew<vtkTransform> transform; // pre-multiplies: T * Ry * Rx * Rz
  transform->Translate(mount[0], mount[1], mount[2]);
  transform->RotateY(mount[3]);
  transform->RotateX(mount[4]);
  transform->RotateZ(mount[5]);
  headsetFromCamera->DeepCopy(transform->GetMatrix());
}

bool HasCameraMount(const Options& options)
{
  return std::any_of(std::begin(options.CameraMount), std::end(options.CameraMount),
    [](double value) { return value != 0.0; });
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
    auto integer = [&](const char* name, int minimum, int maximum)
    { return holovolume::IntegerOption("holovolume", name, value(name), minimum, maximum); };
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
    {
      const std::string intensity = value("--environment-intensity");
      options.AutoEnvironmentIntensity = intensity == "auto";
      options.EnvironmentIntensity =
        options.AutoEnvironmentIntensity ? 1.0 : std::atof(intensity.c_str());
    }
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
      options.Width = integer("--width", 1, 16384);
    else if (argument == "--height")
      options.Height = integer("--height", 1, 16384);
    else if (argument == "--spp")
      options.SamplesPerPixel = integer("--spp", 1, 1 << 20);
    else if (argument == "--frames")
      options.Frames = integer("--frames", 1, 1000000);
    else if (argument == "--bounces")
    {
      // vtkPathTracedVolumeMapper::SetMaximumBounces clamps to 1-1024.
      options.Bounces = integer("--bounces", 1, 1024);
    }
    else if (argument == "--mono")
      options.Stereo = false;
    else if (argument == "--ipd")
      options.InterpupillaryDistance = std::atof(value("--ipd"));
    else if (argument == "--azimuth")
      options.Azimuth = std::atof(value("--azimuth"));
    else if (argument == "--seed")
      options.Seed = static_cast<unsigned int>(integer("--seed", 0, 2147483647));
    else if (argument == "--threads")
      options.Threads = integer("--threads", 0, 1024);
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
    else if (argument == "--camera")
      options.Camera = value("--camera");
    else if (argument == "--serve")
      options.Serve = true;
    else if (argument == "--port")
      options.Port = integer("--port", 0, 65535);
    else if (argument == "--listen")
      options.Listen = value("--listen");
    else if (argument == "--allow-remote")
      options.AllowRemote = true;
    else if (argument == "--token")
      options.Token = value("--token");
    else if (argument == "--certificate")
      options.Certificate = value("--certificate");
    else if (argument == "--private-key")
      options.PrivateKey = value("--private-key");
    else if (argument == "--codec")
      options.Codec = value("--codec");
    else if (argument == "--eye-size")
    {
      const std::string size = value("--eye-size");
      if (std::sscanf(size.c_str(), "%dx%d", &options.EyeWidth, &options.EyeHeight) != 2 ||
        options.EyeWidth < 2 || options.EyeHeight < 2)
      {
        std::cerr << "holovolume: --eye-size needs WIDTHxHEIGHT, e.g. 1440x936\n";
        return false;
      }
    }
    else if (argument == "--no-denoiser")
      options.Denoise = false;
    else if (argument == "--denoise")
      options.DenoiseFrames = true;
    else if (argument == "--save-frames")
      options.SaveFrames = true;
    else if (argument == "--serve-seconds")
      options.ServeSeconds = std::atof(value("--serve-seconds"));
    else if (argument == "--serve-frames")
      options.ServeFrames = integer("--serve-frames", 0, std::numeric_limits<int>::max());
    else if (argument == "--web-root")
      options.WebRoot = value("--web-root");
    else if (argument == "--calibration")
      options.Calibration = value("--calibration");
    else if (argument == "--camera-frames")
      options.CameraFrames = integer("--camera-frames", 1, 1000000);
    else if (argument == "--camera-no-pacing")
      options.CameraPacing = false;
    else if (argument == "--camera-every-frame")
      options.CameraEveryFrame = true;
    else if (argument == "--camera-loop")
      options.CameraLoop = true;
    else if (argument == "--camera-wait")
      options.CameraWait = std::atof(value("--camera-wait"));
    else if (argument == "--proxy-radius")
      options.ProxyRadius = std::atof(value("--proxy-radius"));
    else if (argument == "--headset-position")
      options.HeadsetPosition = value("--headset-position");
    else if (argument == "--camera-mount")
    {
      const std::string mount = value("--camera-mount");
      if (!ParseCameraMount(mount, options.CameraMount))
      {
        std::cerr << "holovolume: --camera-mount takes X,Y,Z[,YAW[,PITCH[,ROLL]]] (volume "
                     "units, then degrees), not '"
                  << mount << "'\n";
        return false;
      }
    }
    else if (argument == "--relight-threshold")
      options.RelightThreshold = std::atof(value("--relight-threshold"));
    else if (argument == "--save-environment")
      options.SaveEnvironment = true;
    else
    {
      std::cerr << "holovolume: unknown option '" << argument << "' (see --help)\n";
      return false;
    }
  }
  if (options.Codec != "jpeg" && options.Codec != "h264")
  {
    std::cerr << "holovolume: --codec must be jpeg or h264\n";
    return false;
  }
  if (options.Serve && options.DenoiseFrames)
  {
    std::cerr << "holovolume: --serve denoises by default (--no-denoiser streams raw frames); "
                 "--denoise is for the image modes\n";
    return false;
  }
  if (options.DenoiseFrames &&
    (options.Models.size() != 1 || options.Models.front() != "path-traced"))
  {
    std::cerr << "holovolume: --denoise denoises the path tracer's frames; leave out --model or "
                 "pass --model path-traced\n";
    return false;
  }
  if (options.ToneMapping != "aces" && options.ToneMapping != "clamp")
  {
    std::cerr << "holovolume: --tone-mapping must be aces or clamp\n";
    return false;
  }
  if (options.Camera.empty() && options.AutoEnvironmentIntensity)
  {
    options.AutoEnvironmentIntensity = false; // an HDR file has its own scale
  }
  if (!(options.EnvironmentIntensity > 0.0))
  {
    std::cerr << "holovolume: --environment-intensity must be positive (or auto with --camera)\n";
    return false;
  }
  if (options.Camera.empty() && HasCameraMount(options))
  {
    std::cerr << "holovolume: --camera-mount says where the 360-degree camera sits on the "
                 "headset; it needs --camera\n";
    return false;
  }
  if (!options.Camera.empty())
  {
    if (!(options.ProxyRadius > 0.0))
    {
      std::cerr << "holovolume: --proxy-radius must be positive (millimetres for NIfTI)\n";
      return false;
    }
    if (!(options.CameraWait >= 0.0 && options.CameraWait <= 3600.0))
    {
      std::cerr << "holovolume: --camera-wait must lie in [0, 3600] seconds\n";
      return false;
    }
    if (!(options.RelightThreshold >= 0.0 && options.RelightThreshold <= 1.0))
    {
      std::cerr << "holovolume: --relight-threshold must lie in [0, 1]\n";
      return false;
    }
    double position[3];
    if (options.HeadsetPosition != "viewer" && options.HeadsetPosition != "center" &&
      options.HeadsetPosition != "origin" &&
      !ParseHeadsetPosition(options.HeadsetPosition, nullptr, nullptr, position))
    {
      std::cerr << "holovolume: --headset-position must be viewer, center, origin or X,Y,Z, not '"
                << options.HeadsetPosition << "'\n";
      return false;
    }
    if (options.Models.size() != 1)
    {
      std::cerr << "holovolume: live mode (--camera) renders one model; choose it with --model\n";
      return false;
    }
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

// Display image of an eye as RGB over a dark background, or RGBA when transparent: the
// mapper's own eye, or an image with "Radiance" like the mapper's (a denoised eye).
vtkSmartPointer<vtkImageData> DisplayImage(
  vtkPathTracedVolumeMapper* mapper, int eye, bool transparent, vtkImageData* radiance = nullptr)
{
  vtkNew<vtkImageData> rgba;
  if (radiance)
  {
    mapper->ComputeDisplayImage(radiance, rgba);
  }
  else
  {
    mapper->ComputeDisplayImage(eye, rgba);
  }
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

// What a frame is rendered with.
struct Scene
{
  vtkPathTracedVolumeMapper* Mapper = nullptr;
  vtkVolume* Volume = nullptr;
  vtkMatrix4x4* View[2] = { nullptr, nullptr };
  vtkMatrix4x4* Projection[2] = { nullptr, nullptr };
  vtkLightCollection* Lights = nullptr; // for the gradient-Phong model
};

void SelectModel(vtkPathTracedVolumeMapper* mapper, const std::string& model)
{
  if (model == "path-traced")
    mapper->SetIlluminationModelToPathTraced();
  else if (model == "emission-absorption")
    mapper->SetIlluminationModelToEmissionAbsorption();
  else if (model == "gradient-phong")
    mapper->SetIlluminationModelToGradientPhong();
  else
    mapper->SetIlluminationModelToPrefilteredEnvironment();
}

bool RenderFrame(const Scene& scene, const Options& options, const std::string& model)
{
  vtkLightCollection* lights = model == "gradient-phong" ? scene.Lights : nullptr;
  const int ok = options.Stereo
    ? scene.Mapper->RenderStereoFrame(scene.Volume, scene.View[0], scene.Projection[0],
        scene.View[1], scene.Projection[1], options.Width, options.Height, lights)
    : scene.Mapper->RenderEye(
        scene.Volume, 0, scene.View[0], scene.Projection[0], options.Width, options.Height, lights);
  if (!ok)
  {
    std::cerr << "\nholovolume: rendering failed (see the message above)\n";
  }
  return ok != 0;
}

// A figure the denoiser put in its left eye's field data ("MeanHistoryLength", "TemporalWeight",
// "IlluminationDifference", ...); 0 before it ran.
double DenoisedField(vtkStereoSpatioTemporalDenoiser* denoiser, const char* name)
{
  vtkImageData* left = denoiser->GetEyeOutput(0);
  vtkDataArray* field = left ? left->GetFieldData()->GetArray(name) : nullptr;
  return field && field->GetNumberOfTuples() > 0 ? field->GetTuple1(0) : 0.0;
}

// --denoise: every frame a fresh render (no progressive accumulation), turned into the frame
// that is shown by the stereo denoiser, as on the headset.
class FrameDenoiser
{
public:
  FrameDenoiser(vtkPathTracedVolumeMapper* mapper, bool stereo)
    : Mapper(mapper)
    , Stereo(stereo)
  {
    mapper->ProgressiveAccumulationOff();
    // Where the radiance map changed, the same paths are shaded under the previous one too, and
    // the denoiser relights its history by the ratio of the two (Documentation/Denoising.md).
    mapper->RenderPreviousLightingOn();
    this->OnError->SetClientData(&this->LastError);
    this->OnError->SetCallback(
      [](vtkObject*, unsigned long, void* clientData, void* callData)
      {
        *static_cast<std::string*>(clientData) =
          callData ? static_cast<const char*>(callData) : "unknown error";
      });
    this->Denoiser->AddObserver(vtkCommand::ErrorEvent, this->OnError);
  }

  // Denoises the mapper's last frame. T is the illumination difference between the radiance
  // map of this frame and that of the frame before (0 when the map was kept).
  bool Denoise(double illuminationDifference)
  {
    this->LastError.clear();
    this->Denoiser->SetIlluminationDifference(illuminationDifference);
    this->Denoiser->SetLeftEyeData(this->Mapper->GetEyeOutput(0));
    this->Denoiser->SetRightEyeData(this->Stereo ? this->Mapper->GetEyeOutput(1) : nullptr);
    this->Denoiser->Update();
    if (!this->LastError.empty())
    {
      std::cerr << "\nholovolume: denoising failed: " << this->LastError << "\n";
      return false;
    }
    ++this->Frames;
    this->MillisecondsSum += this->Denoiser->GetLastFrameMilliseconds();
    return true;
  }

  vtkImageData* GetEyeOutput(int eye) { return this->Denoiser->GetEyeOutput(eye); }
  double GetLastMilliseconds() { return this->Denoiser->GetLastFrameMilliseconds(); }
  // Over the frames denoised so far.
  double GetMeanMilliseconds() const
  {
    return this->Frames ? this->MillisecondsSum / this->Frames : 0.0;
  }
  double GetField(const char* name) { return DenoisedField(this->Denoiser, name); }

private:
  vtkPathTracedVolumeMapper* Mapper;
  bool Stereo;
  vtkNew<vtkStereoSpatioTemporalDenoiser> Denoiser;
  vtkNew<vtkCallbackCommand> OnError;
  std::string LastError;
  int Frames = 0;
  double MillisecondsSum = 0.0;
};

// Mean luminance (Rec. 709) of the linear "Radiance" of the eyes, over all their pixels: the
// raw and the denoised frame compared, it tells whether the denoised frame follows the light.
double MeanRadiance(vtkImageData* left, vtkImageData* right)
{
  double sum = 0.0;
  vtkIdType count = 0;
  for (vtkImageData* eye : { left, right })
  {
    auto* radiance =
      eye ? vtkFloatArray::SafeDownCast(eye->GetPointData()->GetArray("Radiance")) : nullptr;
    if (!radiance || radiance->GetNumberOfComponents() < 3 ||
      radiance->GetNumberOfComponents() > 4) // RGB or RGBA, as cv::sum takes them
    {
      continue;
    }
    // Luminance is linear: the luminance of the channels' sums is the sum of the luminances.
    const vtkIdType pixels = radiance->GetNumberOfTuples();
    const cv::Scalar channelSums = cv::sum(cv::Mat(1, static_cast<int>(pixels),
      CV_32FC(radiance->GetNumberOfComponents()), radiance->GetPointer(0)));
    sum += 0.2126 * channelSums[0] + 0.7152 * channelSums[1] + 0.0722 * channelSums[2];
    count += pixels;
  }
  return count ? sum / count : 0.0;
}

// Two eyes' display images side by side, left first.
vtkSmartPointer<vtkImageData> SideBySide(vtkImageData* left, vtkImageData* right)
{
  vtkNew<vtkImageAppend> append;
  append->SetAppendAxis(0);
  append->AddInputData(left);
  append->AddInputData(right);
  append->Update();
  return append->GetOutput();
}

// An eye's display image: the denoised eye when a denoiser is given, the mapper's otherwise.
vtkSmartPointer<vtkImageData> ShownEyeImage(
  vtkPathTracedVolumeMapper* mapper, FrameDenoiser* denoiser, const Options& options, int eye)
{
  return DisplayImage(
    mapper, eye, options.Transparent, denoiser ? denoiser->GetEyeOutput(eye) : nullptr);
}

// The displayed frame's image as one PNG (side by side for stereo): the denoised eyes when a
// denoiser is given, the mapper's otherwise. For --save-frames.
void WriteFrameImage(vtkPathTracedVolumeMapper* mapper, FrameDenoiser* denoiser,
  const Options& options, const std::string& path)
{
  auto eyeImage = [&](int eye) { return ShownEyeImage(mapper, denoiser, options, eye); };
  if (!options.Stereo)
  {
    WritePNG(eyeImage(0), path);
    return;
  }
  WritePNG(SideBySide(eyeImage(0), eyeImage(1)), path);
}

// DIR/frames/<name>-NNNN.png, NNNN counting from 0001.
std::string FrameImagePath(const Options& options, const std::string& name, int frame)
{
  char number[16];
  std::snprintf(number, sizeof(number), "%04d", frame + 1);
  return options.Output + "/frames/" + name + "-" + number + ".png";
}

// Writes the display images of the last frame (and with --save-buffers each eye's buffers):
// <prefix>-{left,right,stereo}.png, or <prefix>.png for a mono view.
void WriteEyeImages(vtkPathTracedVolumeMapper* mapper, const Options& options,
  const std::string& prefix, FrameDenoiser* denoiser = nullptr)
{
  auto eyeImage = [&](int eye) { return ShownEyeImage(mapper, denoiser, options, eye); };
  if (options.Stereo)
  {
    auto left = eyeImage(0);
    auto right = eyeImage(1);
    WritePNG(left, prefix + "-left.png");
    WritePNG(right, prefix + "-right.png");
    WritePNG(SideBySide(left, right), prefix + "-stereo.png");
    std::cout << "               wrote " << prefix << "-{left,right,stereo}.png\n";
  }
  else
  {
    WritePNG(eyeImage(0), prefix + ".png");
    std::cout << "               wrote " << prefix << ".png\n";
  }
  if (options.SaveBuffers)
  {
    for (int eye = 0; eye < (options.Stereo ? 2 : 1); ++eye)
    {
      vtkNew<vtkXMLImageDataWriter> writer;
      writer->SetInputData(denoiser ? denoiser->GetEyeOutput(eye) : mapper->GetEyeOutput(eye));
      const std::string path = prefix + (eye == 0 ? "-left" : "-right") + "-buffers.vti";
      writer->SetFileName(path.c_str());
      writer->Write();
      std::cout << "               wrote " << path << "\n";
    }
  }
}

// ---- Live mode ----

// A float RGB(A) image's scalars as an OpenCV image in the lighting kernels' conventions
// (RGB, row 0 at the top): VTK's rows run from the bottom up.
cv::Mat ToTopDownRgb(vtkImageData* image)
{
  int dims[3];
  image->GetDimensions(dims);
  vtkDataArray* scalars = image->GetPointData()->GetScalars();
  if (!scalars || dims[0] < 1 || dims[1] < 1 ||
    (scalars->GetNumberOfComponents() != 3 && scalars->GetNumberOfComponents() != 4))
  {
    return cv::Mat();
  }
  int depth;
  switch (scalars->GetDataType())
  {
    case VTK_UNSIGNED_CHAR:
      depth = CV_8U;
      break;
    case VTK_UNSIGNED_SHORT:
      depth = CV_16U;
      break;
    case VTK_FLOAT:
      depth = CV_32F;
      break;
    default:
      return cv::Mat();
  }
  const cv::Mat wrapped(dims[1], dims[0], CV_MAKETYPE(depth, scalars->GetNumberOfComponents()),
    scalars->GetVoidPointer(0));
  cv::Mat flipped, rgb;
  cv::flip(wrapped, flipped, 0);
  if (flipped.channels() == 4)
  {
    cv::cvtColor(flipped, rgb, cv::COLOR_RGBA2RGB);
    return rgb;
  }
  return flipped;
}

// Writes a panorama for people to look at. HDR radiance (toneMap) goes through Reinhard et
// al.'s global operator (2002; OpenCV's photo module, display gamma 2.2); a camera's linear
// panorama (1 = the sensor's clip level) is encoded back to sRGB as the camera recorded it.
bool WritePanoramaPNG(vtkImageData* image, const std::string& path, bool toneMap)
{
  const cv::Mat rgb = ToTopDownRgb(image);
  if (rgb.empty())
  {
    return false;
  }
  cv::Mat rgb8;
  if (rgb.depth() == CV_8U)
  {
    rgb8 = rgb;
  }
  else if (rgb.depth() == CV_16U)
  {
    rgb.convertTo(rgb8, CV_8U, 1.0 / 257.0);
  }
  else if (toneMap)
  {
    cv::Mat bgr, mapped;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR); // the operator's luminance weights assume BGR
    // Global adaptation (light_adapt 0): per-pixel adaptation lifts the noise of dark
    // texels into coloured blotches.
    cv::createTonemapReinhard(2.2f, 0.0f, 0.0f, 0.0f)->process(bgr, mapped);
    cv::Mat bgr8;
    mapped.convertTo(bgr8, CV_8U, 255.0);
    return cv::imwrite(path, bgr8);
  }
  else
  {
    hv::lighting::CameraResponse().encode(rgb, rgb8);
  }
  cv::Mat bgr8;
  cv::cvtColor(rgb8, bgr8, cv::COLOR_RGB2BGR);
  return cv::imwrite(path, bgr8);
}

// Mean Rec. 709 luminance of an equirectangular radiance map over the sphere: rows are
// weighted by sin(theta), the solid angle of their texels.
double MeanLuminance(vtkImageData* map)
{
  const cv::Mat rgb = ToTopDownRgb(map);
  if (rgb.empty() || rgb.depth() != CV_32F)
  {
    return 0.0;
  }
  cv::Mat luminance, rowMeans;
  cv::transform(rgb, luminance, cv::Matx13f(0.2126f, 0.7152f, 0.0722f));
  cv::reduce(luminance, rowMeans, 1, cv::REDUCE_AVG, CV_64F);
  double sum = 0.0, weights = 0.0;
  for (int row = 0; row < rowMeans.rows; ++row)
  {
    const double weight = std::sin(vtkMath::Pi() * (row + 0.5) / rowMeans.rows);
    sum += weight * rowMeans.at<double>(row);
    weights += weight;
  }
  return sum / weights;
}

// Checks --calibration and sets it on the stitcher: a preset, or a calibration file that
// loads and validates ('equirectangular' needs no stitcher and is handled by the caller).
bool ConfigureCalibration(const std::string& calibration, vtkDualFisheyeToEquirectangular* stitcher)
{
  std::string presets;
  for (int i = 0; i < vtkDualFisheyeToEquirectangular::GetNumberOfPresets(); ++i)
  {
    const std::string name = vtkDualFisheyeToEquirectangular::GetPresetName(i);
    if (calibration == name)
    {
      stitcher->SetPreset(name.c_str());
      return true;
    }
    presets += (presets.empty() ? "" : ", ") + name;
  }
  if (!holovolume::FileExists(calibration))
  {
    std::cerr << "holovolume: --calibration '" << calibration << "' is neither a preset ("
              << presets << "), 'equirectangular', nor a calibration JSON file "
              << "(Documentation/FisheyeCalibration.md)\n";
    return false;
  }
  try
  {
    hv::lighting::loadCalibration(calibration);
  }
  catch (const std::exception& error)
  {
    std::cerr << "holovolume: calibration file '" << calibration
              << "' is not usable: " << error.what() << "\n";
    return false;
  }
  stitcher->SetCalibrationFileName(calibration.c_str());
  return true;
}

// Files that do not exist are reported before anything is loaded; cameras, streams and
// numbered images are checked when they are opened.
bool CheckCameraSource(const std::string& source)
{
  const hv::lighting::PanoramaSourceKind kind =
    hv::lighting::PanoramaFrameGrabber::classifySource(source);
  if ((kind == hv::lighting::PanoramaSourceKind::VideoFile ||
        kind == hv::lighting::PanoramaSourceKind::ImageFile) &&
    !holovolume::FileExists(source))
  {
    std::cerr << "holovolume: camera source '" << source << "' not found. Give a video file, "
              << "an image, numbered images (frames/theta_%04d.png), /dev/videoN or a stream "
              << "URL; holovolume-simulate-camera makes a video without a camera.\n";
    return false;
  }
  return true;
}

// The live lighting chain of a 360-degree camera (--camera): vtkPanoramaVideoSource ->
// vtkDualFisheyeToEquirectangular (unless the frames are panoramas already) ->
// vtkEnvironmentSyncedLight, and the radiance map the mapper renders with. That map is a copy,
// replaced only when the newest map differs from it by --relight-threshold, so that the
// mapper's accumulation restarts (or the denoiser relights its history) only when the light
// changed, not at every camera frame (sensor noise and compression change each frame a little).
class LiveLighting
{
public:
  enum Stage
  {
    CopyStage,
    StitchStage,
    SyncedStage,
    RelightStage,
    Stages
  };

  LiveLighting(const Options& options, vtkPathTracedVolumeMapper* mapper)
    : Options_(options)
    , Mapper(mapper)
    , Equirectangular(options.Calibration == "equirectangular")
  {
  }

  // Builds the chain; false after a message (a calibration that does not load).
  bool Build()
  {
    this->Source->SetSource(this->Options_.Camera.c_str());
    this->Source->SetPaceToFrameRate(this->Options_.CameraPacing);
    this->Source->SetDeliverEveryFrame(this->Options_.CameraEveryFrame);
    this->Source->SetLoop(this->Options_.CameraLoop);
    // Each frame takes the newest camera frame once, at its start (UpdateToNewestFrame), so
    // that the stages see the same frame.
    this->Source->AutoAdvanceOff();
    vtkNew<vtkMatrix4x4> headsetFromCamera;
    CameraMountMatrix(this->Options_.CameraMount, headsetFromCamera);
    this->Synced->SetCameraMountTransform(headsetFromCamera);
    if (this->Equirectangular)
    {
      this->Synced->SetInputConnection(this->Source->GetOutputPort());
      return true;
    }
    if (!ConfigureCalibration(this->Options_.Calibration, this->Stitcher))
    {
      return false;
    }
    this->Stitcher->SetInputConnection(this->Source->GetOutputPort());
    this->Synced->SetInputConnection(this->Stitcher->GetOutputPort());
    return true;
  }

  // Opens the camera and prints what it is; false after a message.
  bool Open()
  {
    if (!this->Source->Open())
    {
      std::cerr << "holovolume: cannot open the camera source '" << this->Options_.Camera
                << "' (see the message above)\n";
      return false;
    }
    std::printf(
      "               %s, %s\n", this->Source->GetSourceKind(), this->Source->GetFrameEncoding());
    return true;
  }

  // One frame's lighting: the newest camera frame (after waiting up to waitSeconds for one
  // newer than the last, when positive) through the chain stage by stage (each Update() finds
  // the stages upstream up to date, so each stage can be timed), and the map in use replaced
  // when the light changed. The first call takes the frame Open() took. False after a message.
  bool Advance(double waitSeconds)
  {
    using Clock = std::chrono::steady_clock;
    auto milliseconds = [](Clock::time_point from, Clock::time_point to)
    { return std::chrono::duration<double, std::milli>(to - from).count(); };
    bool newer = false;
    if (this->Advanced && waitSeconds > 0.0)
    {
      newer = this->Source->WaitForNewFrame(waitSeconds);
    }
    const auto t0 = Clock::now();
    if (this->Advanced && !newer)
    {
      this->Source->UpdateToNewestFrame();
    }
    this->Advanced = true;
    bool ok = this->Source->GetExecutive()->Update();
    const auto t1 = Clock::now();
    ok = ok && (this->Equirectangular || this->Stitcher->GetExecutive()->Update());
    const auto t2 = Clock::now();
    ok = ok && this->Synced->GetExecutive()->Update() &&
      this->Synced->GetOutput()->GetNumberOfPoints() > 0;
    const auto t3 = Clock::now();
    if (!ok)
    {
      std::cerr << "\nholovolume: the lighting chain failed on camera frame "
                << this->Source->GetFrameIndex() << " (see the message above)"
                << (this->Equirectangular
                       ? "; equirectangular frames must be twice as wide as high, and "
                         "dual-fisheye frames need the camera's --calibration"
                       : "; if the frames are already panoramas, pass "
                         "--calibration equirectangular")
                << "\n";
      return false;
    }
    this->CameraFrame = this->Source->GetFrameIndex();
    this->NewCameraFrame = this->CameraFrame != this->LastCameraFrame;
    this->LastCameraFrame = this->CameraFrame;
    // A new map comes from a new camera frame, or from the same one seen from another pose.
    const vtkMTimeType mapTime = this->Synced->GetOutput()->GetMTime();
    const bool newMap = mapTime != this->LastMapTime;
    this->LastMapTime = mapTime;
    this->Replaced = false;
    this->MapDifference = 0.0;
    if (!this->HaveMap)
    {
      this->Replaced = true;
    }
    else if (newMap)
    {
      // How far the newest map is from the one in use (the same log-SSIM measure as T).
      auto* current =
        vtkFloatArray::SafeDownCast(this->Synced->GetOutput()->GetPointData()->GetScalars());
      auto* used = vtkFloatArray::SafeDownCast(this->InUse->GetPointData()->GetScalars());
      int dims[3];
      this->InUse->GetDimensions(dims);
      const cv::Mat previousMap(dims[1], dims[0], CV_32FC3, used->GetPointer(0));
      const cv::Mat currentMap(dims[1], dims[0], CV_32FC3, current->GetPointer(0));
      this->MapDifference = this->Difference.compute(previousMap, currentMap);
      this->Replaced = this->MapDifference >= this->Options_.RelightThreshold;
    }
    if (this->Replaced)
    {
      this->InUse->DeepCopy(this->Synced->GetOutput());
      this->InUse->Modified();
      ++this->Replacements;
      if (!this->HaveMap)
      {
        this->InstallFirstMap();
      }
    }
    const auto t4 = Clock::now();
    this->StageMilliseconds[CopyStage] = milliseconds(t0, t1);
    this->StageMilliseconds[StitchStage] = milliseconds(t1, t2);
    this->StageMilliseconds[SyncedStage] = milliseconds(t2, t3);
    this->StageMilliseconds[RelightStage] = milliseconds(t3, t4);
    return true;
  }

  vtkPanoramaVideoSource* GetSource() { return this->Source; }
  vtkEnvironmentSyncedLight* GetSyncedLight() { return this->Synced; }
  vtkImageData* GetMapInUse() { return this->InUse; }
  // The stitched camera panorama (the camera's frame when it is a panorama already).
  vtkImageData* GetCameraPanorama()
  {
    return vtkImageData::SafeDownCast(this->Equirectangular
        ? this->Source->GetOutputDataObject(0)
        : this->Stitcher->GetOutputDataObject(0));
  }
  bool IsEquirectangular() const { return this->Equirectangular; }

  // What the last Advance() found.
  vtkTypeInt64 CameraFrame = -1;
  bool NewCameraFrame = false;
  // The map in use was replaced, and by how much it differs from the one it replaced: the
  // denoiser's T. Not the synced light's own T, which compares consecutive camera frames,
  // while the map in use is replaced only once the light has drifted past the threshold.
  bool Replaced = false;
  double MapDifference = 0.0;
  double StageMilliseconds[Stages] = { 0.0, 0.0, 0.0, 0.0 };
  int Replacements = 0;

private:
  void InstallFirstMap()
  {
    this->Mapper->SetEnvironmentMapData(this->InUse);
    this->HaveMap = true;
    if (!this->Options_.AutoEnvironmentIntensity)
    {
      return;
    }
    // An LDR camera gives radiance relative to its clip level, not absolute radiance: like a
    // photographer's exposure, the scale is fixed once, from the first map, so that later
    // changes of the light (a lamp switching on) still show.
    const double mean = MeanLuminance(this->InUse);
    const double intensity = mean > 0.0 ? AutoMeanLuminance / mean : 1.0;
    this->Mapper->SetEnvironmentIntensity(intensity);
    if (isatty(fileno(stderr)))
    {
      std::fprintf(stderr, "\r%80s\r", "");
    }
    std::printf("Environment  intensity x%.4g (auto: mean radiance %.4g of the first map to "
                "%.2g; --environment-intensity sets it)\n",
      intensity, mean, AutoMeanLuminance);
  }

  const Options& Options_;
  vtkPathTracedVolumeMapper* Mapper;
  const bool Equirectangular;
  vtkNew<vtkPanoramaVideoSource> Source;
  vtkNew<vtkDualFisheyeToEquirectangular> Stitcher;
  vtkNew<vtkEnvironmentSyncedLight> Synced;
  vtkNew<vtkImageData> InUse;
  hv::lighting::IlluminationDifference Difference;
  bool HaveMap = false;
  bool Advanced = false;
  vtkTypeInt64 LastCameraFrame = -1;
  vtkMTimeType LastMapTime = 0;
};

// Live mode: every frame takes the newest camera frame through the lighting chain (stitching,
// world alignment and volume-centred warp, HDR estimation, T), installs the new radiance map
// when the light changed, and renders one more progressive frame, or with --denoise a fresh
// frame that the denoiser turns into the shown one.
int RenderLive(const Options& options, const Scene& scene, vtkImageData* volumeData,
  vtkCamera* camera, vtkMatrix4x4* environmentToWorld, ProgressState& progress)
{
  const std::string& model = options.Models.front();
  vtkPathTracedVolumeMapper* mapper = scene.Mapper;

  LiveLighting lighting(options, mapper);
  if (!lighting.Build())
  {
    return 2;
  }
  vtkEnvironmentSyncedLight* synced = lighting.GetSyncedLight();
  const bool equirectangular = lighting.IsEquirectangular();

  // Frames. The synced light works in a room frame: +Y up, the frame of an upright headset,
  // in which the camera panorama is defined; the volume's world (RAS for NIfTI, millimetres)
  // is that room turned by environmentToWorld, the same rotation the still mode gives an HDR
  // panorama. The headset is upright, facing the room's -Z (turned by --environment-yaw): its
  // pose is the identity rotation and its position, and the camera sits on it as
  // --camera-mount says (by default at its origin, front lens along its -Z). Q comes out in the
  // room frame, and the mapper turns it into the world with environmentToWorld. Positions and the
  // proxy radius are in the volume's units.
  double bounds[6];
  volumeData->GetBounds(bounds);
  const double volumeCenter[3] = { 0.5 * (bounds[0] + bounds[1]), 0.5 * (bounds[2] + bounds[3]),
    0.5 * (bounds[4] + bounds[5]) };
  double headsetPosition[3];
  if (!ParseHeadsetPosition(options.HeadsetPosition, camera, volumeCenter, headsetPosition))
  {
    std::cerr << "holovolume: --headset-position must be viewer, center, origin or X,Y,Z, not '"
              << options.HeadsetPosition << "'\n";
    return 2;
  }
  auto toRoom = [&](const double world[3], double room[3])
  {
    for (int i = 0; i < 3; ++i)
    {
      room[i] = 0.0;
      for (int j = 0; j < 3; ++j)
      {
        room[i] += environmentToWorld->GetElement(j, i) * world[j];
      }
    }
  };
  double roomHeadset[3], roomCenter[3];
  toRoom(headsetPosition, roomHeadset);
  toRoom(volumeCenter, roomCenter);
  vtkNew<vtkMatrix4x4> headsetPose;
  for (int i = 0; i < 3; ++i)
  {
    headsetPose->SetElement(i, 3, roomHeadset[i]);
  }
  synced->SetHeadsetPose(headsetPose);
  synced->SetVolumeCenter(roomCenter);
  synced->SetProxyRadius(options.ProxyRadius);
  // The camera's pose in the world: the upright headset's, then the mount Build() gave the
  // synced light (room and headset axes agree, and the world is the room turned by
  // environmentToWorld).
  vtkNew<vtkMatrix4x4> worldFromCamera;
  vtkMatrix4x4::Multiply4x4(environmentToWorld, synced->GetCameraMountTransform(), worldFromCamera);
  double cameraPosition[3], front[3];
  for (int i = 0; i < 3; ++i)
  {
    cameraPosition[i] = headsetPosition[i] + worldFromCamera->GetElement(i, 3);
    front[i] = -worldFromCamera->GetElement(i, 2);
  }
  const double distance = std::sqrt(vtkMath::Distance2BetweenPoints(cameraPosition, volumeCenter));
  const double diagonal = std::sqrt((bounds[1] - bounds[0]) * (bounds[1] - bounds[0]) +
    (bounds[3] - bounds[2]) * (bounds[3] - bounds[2]) +
    (bounds[5] - bounds[4]) * (bounds[5] - bounds[4]));
  if (distance >= options.ProxyRadius)
  {
    std::cerr << "holovolume: the volume's centre is " << distance
              << " units from the camera, outside the proxy room (--proxy-radius "
              << options.ProxyRadius << "); give the room's real size, in the volume's units\n";
    return 2;
  }
  std::printf("Camera       %s (%s)\n", options.Camera.c_str(),
    equirectangular ? "equirectangular frames" : options.Calibration.c_str());
  if (HasCameraMount(options))
  {
    std::printf("             mounted (%.0f, %.0f, %.0f) from the headset at (%.0f, %.0f, %.0f), "
                "turned yaw %.1f, pitch %.1f, roll %.1f degrees\n",
      options.CameraMount[0], options.CameraMount[1], options.CameraMount[2], headsetPosition[0],
      headsetPosition[1], headsetPosition[2], options.CameraMount[3], options.CameraMount[4],
      options.CameraMount[5]);
  }
  std::printf("Lighting     camera at (%.0f, %.0f, %.0f), %.0f from the volume centre (%.0f, "
              "%.0f, %.0f); front lens along (%.2f, %.2f, %.2f)%s; proxy room: sphere "
              "of radius %.0f (volume units: mm for NIfTI)\n",
    cameraPosition[0], cameraPosition[1], cameraPosition[2], distance, volumeCenter[0],
    volumeCenter[1], volumeCenter[2], front[0], front[1], front[2],
    options.CameraMount[4] == 0.0 && options.CameraMount[5] == 0.0 ? ", upright" : "",
    options.ProxyRadius);
  if (options.ProxyRadius > 100.0 * diagonal)
  {
    std::cerr << "holovolume: note: the volume is " << diagonal << " units across and the proxy "
              << "room " << options.ProxyRadius << "; if the volume is in metres, pass "
              << "--proxy-radius in metres too\n";
  }

  if (!lighting.Open())
  {
    return 1;
  }
  SelectModel(mapper, model);
  std::unique_ptr<FrameDenoiser> denoiser;
  if (options.DenoiseFrames)
  {
    denoiser = std::make_unique<FrameDenoiser>(mapper, options.Stereo);
  }
  const std::string prefix = options.Output + "/live-" + model;
  if (options.SaveFrames)
  {
    mkdir((options.Output + "/frames").c_str(), 0755);
  }

  progress.Label = "live " + model;
  progress.Frames = options.CameraFrames;
  // Milliseconds summed over the frames: frame copy, stitching, synced light, relight test.
  double total[LiveLighting::Stages] = { 0.0, 0.0, 0.0, 0.0 };
  double renderTotal = 0.0;
  using Clock = std::chrono::steady_clock;
  auto milliseconds = [](Clock::time_point from, Clock::time_point to)
  { return std::chrono::duration<double, std::milli>(to - from).count(); };
  const auto start = Clock::now();
  for (progress.Frame = 0; progress.Frame < progress.Frames; ++progress.Frame)
  {
    // The newest camera frame through the lighting chain. With --camera-wait, wait for a newer
    // one (the wait is not lighting time); otherwise take whatever is newest, never waiting.
    if (!lighting.Advance(options.CameraWait))
    {
      return 1;
    }
    const vtkTypeInt64 cameraFrame = lighting.CameraFrame;
    const bool newCameraFrame = lighting.NewCameraFrame;
    const bool relit = lighting.Replaced;
    const double mapDifference = lighting.MapDifference;
    const auto renderStart = Clock::now();
    if (!RenderFrame(scene, options, model))
    {
      return 1;
    }
    const double renderMilliseconds = milliseconds(renderStart, Clock::now());
    if (denoiser && !denoiser->Denoise(relit ? mapDifference : 0.0))
    {
      return 1;
    }
    double lightingMilliseconds = 0.0;
    for (int i = 0; i < LiveLighting::Stages; ++i)
    {
      total[i] += lighting.StageMilliseconds[i];
      lightingMilliseconds += lighting.StageMilliseconds[i];
    }
    renderTotal += renderMilliseconds;
    if (isatty(fileno(stderr)))
    {
      std::fprintf(stderr, "\r%80s\r", "");
    }
    vtkPolyData* detected = synced->GetDetectedLights();
    std::printf("  frame %3d/%d  camera frame %lld%s  T %.3f  lights %lld  lighting %.1f ms  "
                "render %.1f ms  ",
      progress.Frame + 1, progress.Frames, static_cast<long long>(cameraFrame),
      newCameraFrame ? "" : " (same)", synced->GetIlluminationDifference(),
      static_cast<long long>(detected ? detected->GetNumberOfPoints() : 0), lightingMilliseconds,
      renderMilliseconds);
    if (denoiser)
    {
      vtkImageData* raw[2] = { mapper->GetEyeOutput(0),
        options.Stereo ? mapper->GetEyeOutput(1) : nullptr };
      std::printf("%s  denoise %.1f ms  history %.1f frames  temporal weight %.3f  "
                  "radiance raw %.4f denoised %.4f\n",
        relit ? "map replaced" : "map kept", denoiser->GetLastMilliseconds(),
        denoiser->GetField("MeanHistoryLength"), denoiser->GetField("TemporalWeight"),
        MeanRadiance(raw[0], raw[1]),
        MeanRadiance(
          denoiser->GetEyeOutput(0), options.Stereo ? denoiser->GetEyeOutput(1) : nullptr));
    }
    else
    {
      std::printf(
        "%s %d\n", relit ? "relit, accumulated" : "accumulated", mapper->GetAccumulatedFrames(0));
    }
    std::fflush(stdout);
    if (options.SaveFrames)
    {
      WriteFrameImage(
        mapper, nullptr, options, FrameImagePath(options, "live-" + model, progress.Frame));
      if (denoiser)
      {
        WriteFrameImage(mapper, denoiser.get(), options,
          FrameImagePath(options, "live-" + model + "-denoised", progress.Frame));
      }
    }
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  const double n = progress.Frames;
  std::printf("  %-24s %d frames in %.2f s; per frame on average: lighting %.1f ms (frame copy "
              "%.1f, stitching %.1f, synced light %.1f, relight test %.1f), render %.1f ms (%s)\n"
              "               radiance map replaced %d times; the camera delivered %lld frames, "
              "%lld of them overwritten before they were taken\n",
    ("live " + model).c_str(), progress.Frames, seconds,
    (total[LiveLighting::CopyStage] + total[LiveLighting::StitchStage] +
      total[LiveLighting::SyncedStage] + total[LiveLighting::RelightStage]) /
      n,
    total[LiveLighting::CopyStage] / n, total[LiveLighting::StitchStage] / n,
    total[LiveLighting::SyncedStage] / n, total[LiveLighting::RelightStage] / n, renderTotal / n,
    options.Stereo ? "stereo" : "mono", lighting.Replacements,
    static_cast<long long>(lighting.GetSource()->GetFramesReceived()),
    static_cast<long long>(lighting.GetSource()->GetFramesDropped()));
  if (denoiser)
  {
    std::printf("               denoised: %.1f ms per frame on average (%s); every frame %d "
                "spp, no accumulation\n",
      denoiser->GetMeanMilliseconds(), options.Stereo ? "both eyes" : "mono",
      options.SamplesPerPixel);
  }

  WriteEyeImages(mapper, options, prefix);
  if (denoiser)
  {
    WriteEyeImages(mapper, options, prefix + "-denoised", denoiser.get());
  }
  if (options.SaveFrames)
  {
    std::cout << "               wrote " << progress.Frames << " frame images to " << options.Output
              << "/frames/live-" << model << "-NNNN.png"
              << (denoiser ? " and live-" + model + "-denoised-NNNN.png" : std::string()) << "\n";
  }
  if (options.SaveEnvironment)
  {
    const std::string environmentPath = options.Output + "/live-environment.png";
    const std::string panoramaPath = options.Output + "/live-camera-panorama.png";
    vtkImageData* cameraPanorama = lighting.GetCameraPanorama();
    // An HDR camera frame (EXR/HDR given as equirectangular) is tone-mapped like Q.
    const bool sceneLinear =
      std::strcmp(lighting.GetSource()->GetFrameEncoding(), "SceneLinear") == 0;
    if (WritePanoramaPNG(lighting.GetMapInUse(), environmentPath, true) &&
      WritePanoramaPNG(cameraPanorama, panoramaPath, equirectangular && sceneLinear))
    {
      std::cout << "               wrote " << environmentPath << ", " << panoramaPath << "\n";
    }
    else
    {
      std::cerr << "holovolume: could not write " << environmentPath << " or " << panoramaPath
                << "\n";
      return 1;
    }
  }
  if (options.SaveBuffers)
  {
    vtkNew<vtkXMLImageDataWriter> writer;
    writer->SetInputData(lighting.GetMapInUse());
    const std::string path = options.Output + "/live-environment.vti";
    writer->SetFileName(path.c_str());
    writer->Write();
    std::cout << "               wrote " << path << "\n";
  }
  lighting.GetSource()->Close();
  return 0;
}
}

vtkHoloLensRemotingOutput* ServingOutput = nullptr;

void StopServing(int)
{
  if (ServingOutput)
  {
    ServingOutput->RequestStop(); // only sets an atomic flag: safe in a signal handler
  }
}

// --serve --camera: the live lighting chain run before each frame the output considers, with
// the 360-degree camera on the headset. Its pose is the viewer's head pose, so the panorama is
// turned into the world as the head turns and re-centred on the volume as the viewer walks
// (the paper's Section 3.1); the room frame of the synced light is the headset's world turned
// back by --environment-yaw. A replaced radiance map is a change of the scene the output
// renders, and its illumination difference is the denoiser's T for the next published frame.
struct StreamedLighting
{
  LiveLighting* Lighting = nullptr;
  vtkHoloLensRemotingOutput* Output = nullptr;
  vtkVolume* Volume = nullptr;
  vtkStereoSpatioTemporalDenoiser* Denoiser = nullptr;
  vtkMatrix4x4* EnvironmentToWorld = nullptr;
  double ProxyRadius = 2500.0;
  double WorldUnitsPerMetre = 1000.0;
  // T of the maps replaced since the last published frame (the largest).
  double PendingIlluminationDifference = 0.0;
  double LastPose[16] = {};
  bool HavePose = false;
  bool Failed = false;
  int Steps = 0;
  int PosesOutsideRoom = 0;
  // Published frames whose denoiser was given T > 0.
  int FramesWithNewLight = 0;
  double Milliseconds = 0.0;

  // One step: the head pose (or, before a controller sent one, where the output's default
  // view stands: 1.6 m above the floor origin, looking along -Z), the newest camera frame, and
  // the map in use replaced when the light changed.
  void Step()
  {
    vtkNew<vtkMatrix4x4> worldFromHead;
    if (!this->Output->GetHeadPose(worldFromHead))
    {
      worldFromHead->SetElement(1, 3, 1.6 * this->WorldUnitsPerMetre);
    }
    vtkNew<vtkMatrix4x4> roomFromWorld;
    vtkMatrix4x4::Transpose(this->EnvironmentToWorld, roomFromWorld); // a rotation
    vtkNew<vtkMatrix4x4> roomFromHead;
    vtkMatrix4x4::Multiply4x4(roomFromWorld, worldFromHead, roomFromHead);
    const double* volumeCenter = this->Volume->GetCenter(); // of its placed bounds, world
    const double center[4] = { volumeCenter[0], volumeCenter[1], volumeCenter[2], 1.0 };
    double roomCenter[4];
    roomFromWorld->MultiplyPoint(center, roomCenter);
    // The warp re-projects the panorama from the camera, mounted on the head as the synced light
    // has it, through a room of ProxyRadius around it; a viewer about to take the camera out of
    // that room keeps the last pose inside it.
    vtkEnvironmentSyncedLight* synced = this->Lighting->GetSyncedLight();
    vtkMatrix4x4* headFromCamera = synced->GetCameraMountTransform();
    const double mountOffset[4] = { headFromCamera->GetElement(0, 3),
      headFromCamera->GetElement(1, 3), headFromCamera->GetElement(2, 3), 1.0 };
    double camera[4];
    roomFromHead->MultiplyPoint(mountOffset, camera);
    if (std::sqrt(vtkMath::Distance2BetweenPoints(camera, roomCenter)) < 0.95 * this->ProxyRadius)
    {
      const double* pose = &roomFromHead->GetData()[0];
      if (!this->HavePose || !std::equal(pose, pose + 16, this->LastPose))
      {
        // Set only when it moved: a new pose makes the synced light execute again.
        std::copy(pose, pose + 16, this->LastPose);
        this->HavePose = true;
        synced->SetHeadsetPose(roomFromHead);
        synced->SetVolumeCenter(roomCenter);
      }
    }
    else
    {
      ++this->PosesOutsideRoom;
    }
    const bool first = this->Steps == 0;
    if (!this->Lighting->Advance(0.0))
    {
      this->Failed = true;
      this->Output->RequestStop();
      return;
    }
    ++this->Steps;
    for (double stage : this->Lighting->StageMilliseconds)
    {
      this->Milliseconds += stage;
    }
    if (this->Lighting->Replaced && !first)
    {
      this->PendingIlluminationDifference =
        std::max(this->PendingIlluminationDifference, this->Lighting->MapDifference);
      std::printf("  the light changed: camera frame %lld, T %.3f against the map in use, "
                  "which it replaces\n",
        static_cast<long long>(this->Lighting->CameraFrame), this->Lighting->MapDifference);
      std::fflush(stdout);
    }
    if (this->Denoiser)
    {
      this->Denoiser->SetIlluminationDifference(this->PendingIlluminationDifference);
    }
  }
};

// Serve mode: the head (or any volume) streamed to a WebXR player in the headset's world.
int Serve(const Options& options, vtkPathTracedVolumeMapper* mapper, vtkVolume* volume,
  double scalarMaximum)
{
  // The headset's world has +Y up, like the panorama: only the optional yaw remains.
  vtkNew<vtkMatrix4x4> environmentToWorld;
  const double yaw = vtkMath::RadiansFromDegrees(options.EnvironmentYaw);
  environmentToWorld->SetElement(0, 0, std::cos(yaw));
  environmentToWorld->SetElement(0, 2, std::sin(yaw));
  environmentToWorld->SetElement(2, 0, -std::sin(yaw));
  environmentToWorld->SetElement(2, 2, std::cos(yaw));
  mapper->SetEnvironmentToWorldMatrix(environmentToWorld);
  mapper->RemoveObservers(vtkCommand::ProgressEvent);

  // Presets the viewer can switch between: the whole head, a translucent head, and the
  // tissue inside the skin.
  vtkNew<vtkVolumeProperty> translucent, inner;
  holovolume::ApplyTranslucentHeadPreset(translucent, scalarMaximum);
  holovolume::ApplyInnerTissuePreset(inner, scalarMaximum);

  vtkNew<vtkHoloLensRemotingOutput> output;
  output->SetVolume(volume);
  output->AddTransferFunctionPreset("head-mri", volume->GetProperty());
  output->AddTransferFunctionPreset("translucent", translucent);
  output->AddTransferFunctionPreset("inner-tissue", inner);
  vtkNew<vtkStereoSpatioTemporalDenoiser> denoiser;
  if (options.Denoise)
  {
    output->SetDenoiser(denoiser);
    // Where the live environment changed, the denoiser relights its history by the ratio of the
    // frame to the same paths under the previous environment (Documentation/Denoising.md).
    mapper->RenderPreviousLightingOn();
    // A preset picked in the headset relights the history instead of dropping it, except where
    // the new preset shows other material. On the head MRI at 96x62 the translucent preset's
    // first frame is 0.9 dB better so, and the inner-tissue preset recovers as with the history
    // dropped (its material test drops 97 % of the histories; 0.1 dB behind at 288x186); a
    // threshold edit loses 2.4 dB instead of 9.3 ("A new transfer function" in
    // Documentation/Denoising.md).
    denoiser->RelightHistoryOnTransferFunctionChangeOn();
  }
  output->SetEyeSize(options.EyeWidth, options.EyeHeight);
  output->SetPort(options.Port);
  output->SetBindAddress(options.Listen.c_str());
  output->SetAllowRemoteConnections(options.AllowRemote);
  output->SetAccessToken(options.Token.empty() ? nullptr : options.Token.c_str());
  output->SetCertificateFile(options.Certificate.empty() ? nullptr : options.Certificate.c_str());
  output->SetPrivateKeyFile(options.PrivateKey.empty() ? nullptr : options.PrivateKey.c_str());
  output->SetWebRoot(options.WebRoot.empty() ? nullptr : options.WebRoot.c_str());
  output->SetCodec(options.Codec == "h264" ? vtkHoloLensRemotingOutput::CODEC_H264
                                           : vtkHoloLensRemotingOutput::CODEC_JPEG);

  std::unique_ptr<LiveLighting> lighting;
  StreamedLighting streamed;
  vtkNew<vtkCallbackCommand> onStep;
  if (!options.Camera.empty())
  {
    lighting = std::make_unique<LiveLighting>(options, mapper);
    if (!lighting->Build())
    {
      return 2;
    }
    lighting->GetSyncedLight()->SetProxyRadius(options.ProxyRadius);
    std::printf("Camera       %s (%s), on the headset: its pose is the viewer's head pose%s; "
                "proxy room: sphere of radius %.0f (volume units: mm for NIfTI)\n",
      options.Camera.c_str(),
      lighting->IsEquirectangular() ? "equirectangular frames" : options.Calibration.c_str(),
      HasCameraMount(options) ? " and --camera-mount" : "", options.ProxyRadius);
    if (!lighting->Open())
    {
      return 1;
    }
    streamed.Lighting = lighting.get();
    streamed.Output = output;
    streamed.Volume = volume;
    streamed.Denoiser = options.Denoise ? denoiser.GetPointer() : nullptr;
    streamed.EnvironmentToWorld = environmentToWorld;
    streamed.ProxyRadius = options.ProxyRadius;
    streamed.WorldUnitsPerMetre = output->GetWorldUnitsPerMetre();
  }
  if (!output->Start())
  {
    return 1;
  }
  if (lighting)
  {
    // The first radiance map before the first frame, from where the default view stands; then
    // one step before each frame the output considers.
    streamed.Step();
    if (streamed.Failed)
    {
      return 1;
    }
    onStep->SetClientData(&streamed);
    onStep->SetCallback(
      [](vtkObject*, unsigned long, void* clientData, void*)
      {
        auto* state = static_cast<StreamedLighting*>(clientData);
        // Nobody watching: the camera's frames are not worth the lighting chain's time.
        if (!state->Failed && state->Output->GetNumberOfClients() > 0)
        {
          state->Step();
        }
      });
    output->AddObserver(vtkCommand::StartEvent, onStep);
  }
  std::cout << "Streaming    " << options.EyeWidth << "x" << options.EyeHeight << " per eye, "
            << options.SamplesPerPixel << " spp, " << (options.Denoise ? "denoised" : "raw") << ", "
            << options.Codec << "\n"
            << "Open " << output->GetUrl() << "\n"
            << "  in the headset's browser (Enter AR/VR) or a desktop browser (side by side).\n"
            << (options.Listen == "127.0.0.1"
                   ? "  Only this machine can connect; a headset needs --listen, --allow-remote and TLS.\n"
                   : "")
            << std::flush;
  ServingOutput = output;
  std::signal(SIGINT, StopServing);
  std::signal(SIGTERM, StopServing);
  double renderSum = 0.0, denoiseSum = 0.0, encodeSum = 0.0;
  vtkNew<vtkCallbackCommand> onFrame;
  struct Totals
  {
    vtkHoloLensRemotingOutput* Output;
    double *Render, *Denoise, *Encode;
    StreamedLighting* Lighting;
  } totals{ output, &renderSum, &denoiseSum, &encodeSum, lighting ? &streamed : nullptr };
  onFrame->SetClientData(&totals);
  onFrame->SetCallback([](vtkObject*, unsigned long, void* clientData, void*) {
    auto* t = static_cast<Totals*>(clientData);
    *t->Render += t->Output->GetLastRenderTime();
    *t->Denoise += t->Output->GetLastDenoiseTime();
    *t->Encode += t->Output->GetLastEncodeTime();
    if (t->Lighting)
    {
      // The T the denoiser used for this frame, from its output: a change of light it relit
      // its history for.
      StreamedLighting* lighting = t->Lighting;
      if (lighting->Denoiser && DenoisedField(lighting->Denoiser, "IlluminationDifference") > 0.0)
      {
        ++lighting->FramesWithNewLight;
      }
      lighting->PendingIlluminationDifference = 0.0; // this frame took the change in
    }
  });
  output->AddObserver(vtkCommand::UpdateDataEvent, onFrame);
  const int frames = output->Run(options.ServeSeconds, options.ServeFrames);
  ServingOutput = nullptr;
  if (frames < 0 || streamed.Failed)
  {
    return 1;
  }
  const double n = std::max(1, frames);
  std::printf("Served %d frames to %llu poses; mean per stereo frame: render %.1f ms, denoise "
              "%.1f ms, encode %.1f ms; %llu frames dropped for slow clients, %llu messages "
              "rejected\n",
    frames, static_cast<unsigned long long>(output->GetNumberOfPosesReceived()), renderSum / n,
    denoiseSum / n, encodeSum / n, static_cast<unsigned long long>(output->GetNumberOfDroppedFrames()),
    static_cast<unsigned long long>(output->GetNumberOfRejectedMessages()));
  if (lighting)
  {
    std::printf("Live lighting: %d steps of the chain (%.1f ms each on average), the camera "
                "delivered %lld frames; the radiance map was replaced %d times, and %d published "
                "frames gave the denoiser the change (T > 0)%s\n",
      streamed.Steps, streamed.Steps ? streamed.Milliseconds / streamed.Steps : 0.0,
      static_cast<long long>(lighting->GetSource()->GetFramesReceived()),
      lighting->Replacements - 1, streamed.FramesWithNewLight,
      streamed.PosesOutsideRoom
        ? (", " + std::to_string(streamed.PosesOutsideRoom) +
            " head poses outside the proxy room kept the last pose inside it")
            .c_str()
        : "");
    lighting->GetSource()->Close();
  }
  output->Stop();
  return 0;
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
  const bool live = !options.Camera.empty();
  if (live && !CheckCameraSource(options.Camera))
  {
    return 1;
  }
  if (live && options.Calibration != "equirectangular")
  {
    // Checked before the volume is read, so that a wrong name fails at once.
    vtkNew<vtkDualFisheyeToEquirectangular> probe;
    if (!ConfigureCalibration(options.Calibration, probe))
    {
      return 2;
    }
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
  if (live)
  {
    // The camera's radiance map comes in RenderLive().
  }
  else if (options.Environment != "uniform")
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
  if (options.Serve)
  {
    return Serve(options, mapper, volume, range[1] > 0 ? range[1] : 255.0);
  }

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
            << options.SamplesPerPixel << " spp x "
            << (live ? options.CameraFrames : options.Frames) << " frames)\n";

  ProgressState progress;
  vtkNew<vtkCallbackCommand> progressCallback;
  progressCallback->SetCallback(OnProgress);
  progressCallback->SetClientData(&progress);
  mapper->AddObserver(vtkCommand::ProgressEvent, progressCallback);

  Scene scene;
  scene.Mapper = mapper;
  scene.Volume = volume;
  for (int eye = 0; eye < 2; ++eye)
  {
    scene.View[eye] = view[eye];
    scene.Projection[eye] = projection[eye];
  }
  scene.Lights = lights;

  if (live)
  {
    return RenderLive(options, scene, volumeData, camera, environmentToWorld, progress);
  }

  std::unique_ptr<FrameDenoiser> denoiser;
  if (options.DenoiseFrames)
  {
    denoiser = std::make_unique<FrameDenoiser>(mapper, options.Stereo);
  }
  if (options.SaveFrames)
  {
    mkdir((options.Output + "/frames").c_str(), 0755);
  }
  for (const std::string& model : options.Models)
  {
    SelectModel(mapper, model);
    // Only the path tracer gains from progressive frames; the others are near-deterministic.
    progress.Label = model;
    progress.Frames = model == "path-traced" ? options.Frames : std::min(options.Frames, 4);
    const std::string name = model + (denoiser ? "-denoised" : "");
    const auto start = std::chrono::steady_clock::now();
    for (progress.Frame = 0; progress.Frame < progress.Frames; ++progress.Frame)
    {
      if (!RenderFrame(scene, options, model))
      {
        return 1;
      }
      // A still view under a still panorama: the light does not change (T = 0).
      if (denoiser && !denoiser->Denoise(0.0))
      {
        return 1;
      }
      if (options.SaveFrames)
      {
        WriteFrameImage(mapper, nullptr, options, FrameImagePath(options, model, progress.Frame));
        if (denoiser)
        {
          WriteFrameImage(
            mapper, denoiser.get(), options, FrameImagePath(options, name, progress.Frame));
        }
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
    WriteEyeImages(mapper, options, prefix);
    if (denoiser)
    {
      vtkImageData* raw[2] = { mapper->GetEyeOutput(0),
        options.Stereo ? mapper->GetEyeOutput(1) : nullptr };
      std::printf("               denoised, every frame %d spp without accumulation: %.1f ms per "
                  "frame on average; last frame: history %.1f frames, radiance raw %.4f denoised "
                  "%.4f\n",
        options.SamplesPerPixel, denoiser->GetMeanMilliseconds(),
        denoiser->GetField("MeanHistoryLength"), MeanRadiance(raw[0], raw[1]),
        MeanRadiance(
          denoiser->GetEyeOutput(0), options.Stereo ? denoiser->GetEyeOutput(1) : nullptr));
      WriteEyeImages(mapper, options, prefix + "-denoised", denoiser.get());
    }
    if (options.SaveFrames)
    {
      std::cout << "               wrote " << progress.Frames << " frame images to "
                << options.Output << "/frames/" << model << "-NNNN.png"
                << (denoiser ? " and " + name + "-NNNN.png" : std::string()) << "\n";
    }
  }
  return 0;
}
