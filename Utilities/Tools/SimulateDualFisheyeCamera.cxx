// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// holovolume-simulate-camera: the dual-fisheye video that a 360-degree camera would record of a
// room given as an HDR panorama, for users without a camera and for the tests of the live mode
// of holovolume. Each frame is the panorama seen through the lens's glare PSF
// (hv/lighting/LensGlare.h), filmed through the calibrated lens model (renderDualFisheye, with
// vignetting and the per-lens gains), encoded to 8-bit sRGB at a fixed exposure that clips a
// given share of the pixels, with sensor noise, and written as H.264 MP4, MJPG AVI or numbered
// PNG images. The camera can turn from frame to frame, and a lamp can switch on.
#include "hv/Equirectangular.h"
#include "hv/lighting/CameraResponse.h"
#include "hv/lighting/DualFisheyeStitcher.h"
#include "hv/lighting/FisheyeCalibration.h"
#include "hv/lighting/LensGlare.h"
#include "hv/lighting/PanoramaFrameGrabber.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace
{
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

const char* const DefaultEnvironment =
  "/usr/share/blender/datafiles/studiolights/world/courtyard.exr";

struct Options
{
  std::string Environment = DefaultEnvironment;
  std::string Camera = "ricoh-theta";
  int Frames = 30;
  cv::Size FrameSize; // empty: the calibration's
  double FramesPerSecond = 30.0;
  double RotateDegreesPerFrame = 0.0;
  int LightSwitchFrame = -1;
  double LampAzimuth = 90.0;
  double LampElevation = 40.0;
  double LampRadiusDegrees = 6.0;
  double LampBrightness = 30.0;
  double ClipPercent = 1.0;
  double Noise = 1.0;
  unsigned int Seed = 0;
  int Supersampling = 2;
  std::string Output = "dual-fisheye.mp4";
};

void PrintHelp()
{
  std::printf(R"(Usage: holovolume-simulate-camera [options]

Writes the dual-fisheye video that a 360-degree camera would record in a room given as an
HDR panorama: the input for 'holovolume --camera' when there is no camera at hand.

Each frame is the panorama seen through the lens glare (a 1-degree core and a faint 5-degree
halo), filmed through the calibrated fisheye lenses (lens model, field of view, vignetting,
per-lens gains), encoded to 8-bit sRGB at a fixed exposure that clips --clip-percent of the
pixels inside the image circles (measured on frame 0 without the extra lamp), plus Gaussian
sensor noise. The camera's front lens looks at the centre of the panorama.

Input
  -e, --environment FILE   HDR panorama (.exr, .hdr; 2:1), or 'synthetic' for a built-in
                           sky, ground and sun [%s]
  -c, --camera NAME|FILE   camera preset (ricoh-theta, insta360-one-x), calibration JSON
                           (Documentation/FisheyeCalibration.md), or 'equirectangular' for
                           a camera that streams stitched panoramas [ricoh-theta]

Motion and light
      --frames N                    frames to write [30]
      --rotate-degrees-per-frame D  the camera turns D degrees about its vertical axis per
                                    frame, to its left for D > 0 (counter-clockwise seen
                                    from above), so the room turns the other way [0]
      --light-switch-frame K        from frame K on, an extra lamp shines: the lighting
                                    changes abruptly there (a spike of T) [-1: never]
      --lamp-direction AZ,EL        the lamp's direction in the panorama in degrees: azimuth
                                    from the panorama centre towards its right, elevation
                                    above the horizon [90,40: to the camera's right]
      --lamp-radius DEG             its angular radius [6]
      --lamp-brightness X           its radiance in multiples of the sensor's clip level [30]

Camera
      --frame-size WxH         frame size; must have the calibration's aspect ratio
                               [the calibration's: 1920x960 for ricoh-theta; 1024x512
                               for equirectangular]
      --fps F                  frame rate written into the video [30]
      --clip-percent P         share of the pixels in the image circles that clip [1]
      --noise SIGMA            sensor noise, standard deviation in 8-bit codes [1]
      --seed N                 seed of the noise [0]
      --supersampling N        N x N samples of the panorama per frame pixel [2]

Output
  -o, --output PATH        .mp4 (H.264; falls back to MJPG .avi where FFmpeg has no H.264
                           encoder), .mkv (H.264), .avi (MJPG), or a numbered image pattern
                           such as frames/theta_%%04d.png (PNG or JPEG by the extension,
                           numbered from 0) [dual-fisheye.mp4]
  -h, --help               this text

Example
  holovolume-simulate-camera --frames 60 --rotate-degrees-per-frame 1 \
    --light-switch-frame 30 --output room.mp4
  holovolume --camera room.mp4 --camera-frames 60
)",
    DefaultEnvironment);
}

[[noreturn]] void Fail(const std::string& message)
{
  std::fprintf(stderr, "holovolume-simulate-camera: %s\n", message.c_str());
  std::exit(EXIT_FAILURE);
}

double ParseNumber(const char* text, const char* option)
{
  char* end = nullptr;
  const double value = std::strtod(text, &end);
  if (end == text || *end != '\0' || !std::isfinite(value))
  {
    Fail(std::string(option) + " needs a number, not '" + text + "'");
  }
  return value;
}

int ParseInteger(const char* text, const char* option)
{
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  if (end == text || *end != '\0' || value < -1000000000L || value > 1000000000L)
  {
    Fail(std::string(option) + " needs an integer, not '" + text + "'");
  }
  return static_cast<int>(value);
}

Options ParseArguments(int argc, char* argv[])
{
  Options options;
  for (int i = 1; i < argc; ++i)
  {
    const std::string argument = argv[i];
    auto value = [&](const char* name) -> const char*
    {
      if (i + 1 >= argc)
      {
        Fail(std::string(name) + " needs a value (see --help)");
      }
      return argv[++i];
    };
    if (argument == "-h" || argument == "--help")
    {
      PrintHelp();
      std::exit(EXIT_SUCCESS);
    }
    else if (argument == "-e" || argument == "--environment")
      options.Environment = value("--environment");
    else if (argument == "-c" || argument == "--camera")
      options.Camera = value("--camera");
    else if (argument == "--frames")
      options.Frames = ParseInteger(value("--frames"), "--frames");
    else if (argument == "--frame-size")
    {
      const std::string size = value("--frame-size");
      int width = 0, height = 0;
      char separator = 0;
      if (std::sscanf(size.c_str(), "%d%c%d", &width, &separator, &height) != 3 ||
        (separator != 'x' && separator != 'X') || width < 16 || height < 8)
      {
        Fail(
          "--frame-size needs WIDTHxHEIGHT of at least 16x8, such as 1920x960, not '" + size + "'");
      }
      options.FrameSize = cv::Size(width, height);
    }
    else if (argument == "--fps")
      options.FramesPerSecond = ParseNumber(value("--fps"), "--fps");
    else if (argument == "--rotate-degrees-per-frame")
      options.RotateDegreesPerFrame =
        ParseNumber(value("--rotate-degrees-per-frame"), "--rotate-degrees-per-frame");
    else if (argument == "--light-switch-frame")
      options.LightSwitchFrame =
        ParseInteger(value("--light-switch-frame"), "--light-switch-frame");
    else if (argument == "--lamp-direction")
    {
      const std::string direction = value("--lamp-direction");
      if (std::sscanf(direction.c_str(), "%lf,%lf", &options.LampAzimuth, &options.LampElevation) !=
          2 ||
        std::abs(options.LampElevation) > 90.0)
      {
        Fail("--lamp-direction needs AZIMUTH,ELEVATION in degrees (elevation within +-90), such "
             "as 30,50, not '" +
          direction + "'");
      }
    }
    else if (argument == "--lamp-radius")
      options.LampRadiusDegrees = ParseNumber(value("--lamp-radius"), "--lamp-radius");
    else if (argument == "--lamp-brightness")
      options.LampBrightness = ParseNumber(value("--lamp-brightness"), "--lamp-brightness");
    else if (argument == "--clip-percent")
      options.ClipPercent = ParseNumber(value("--clip-percent"), "--clip-percent");
    else if (argument == "--noise")
      options.Noise = ParseNumber(value("--noise"), "--noise");
    else if (argument == "--seed")
      options.Seed = static_cast<unsigned int>(ParseInteger(value("--seed"), "--seed"));
    else if (argument == "--supersampling")
      options.Supersampling = ParseInteger(value("--supersampling"), "--supersampling");
    else if (argument == "-o" || argument == "--output")
      options.Output = value("--output");
    else
      Fail("unknown option '" + argument + "' (see --help)");
  }
  if (options.Frames < 1)
    Fail("--frames must be at least 1");
  if (!(options.FramesPerSecond > 0.0 && options.FramesPerSecond <= 1000.0))
    Fail("--fps must lie in (0, 1000]");
  if (!(options.ClipPercent > 0.0 && options.ClipPercent < 50.0))
    Fail("--clip-percent must lie in (0, 50)");
  if (!(options.Noise >= 0.0 && options.Noise <= 64.0))
    Fail("--noise must lie in [0, 64] codes");
  if (!(options.LampRadiusDegrees > 0.0 && options.LampRadiusDegrees <= 90.0))
    Fail("--lamp-radius must lie in (0, 90] degrees");
  if (!(options.LampBrightness > 0.0))
    Fail("--lamp-brightness must be positive");
  if (options.Supersampling < 1 || options.Supersampling > 8)
    Fail("--supersampling must lie in [1, 8]");
  return options;
}

// A sky, a ground and a sun, in linear radiance (relative units), for users without
// blender-data: sky radiance falls from 1.0 at the horizon to 0.5 at the zenith (a clear sky is
// darker overhead) and brightens up to 2.5 x towards the sun (circumsolar light), the ground
// reflects about a quarter of it, and a sun of 2 degrees radius stands at
// azimuth -40, elevation 35 degrees at 2000 x the horizon's radiance (about 20 % of the
// irradiance on a surface facing it, far below a real sun's share; 8-bit cameras clip it
// either way).
cv::Mat SyntheticEnvironment()
{
  const int width = 1024, height = 512;
  cv::Mat panorama(height, width, CV_32FC3);
  const double sunAzimuth = -40.0 * CV_PI / 180.0, sunElevation = 35.0 * CV_PI / 180.0;
  const glm::vec3 sun(static_cast<float>(std::sin(sunAzimuth) * std::cos(sunElevation)),
    static_cast<float>(std::sin(sunElevation)),
    static_cast<float>(-std::cos(sunAzimuth) * std::cos(sunElevation)));
  const float cosSun = static_cast<float>(std::cos(2.0 * CV_PI / 180.0));
  for (int row = 0; row < height; ++row)
  {
    for (int column = 0; column < width; ++column)
    {
      const glm::vec3 d =
        hv::equirectangularToDirection(glm::vec2((column + 0.5f) / width, (row + 0.5f) / height));
      cv::Vec3f radiance;
      if (d.y >= 0.0f)
      {
        const float circumsolar = std::pow(std::max(0.0f, glm::dot(d, sun)), 8.0f);
        const float sky = (1.0f - 0.5f * d.y) * (1.0f + 1.5f * circumsolar);
        radiance = cv::Vec3f(0.55f, 0.75f, 1.0f) * sky;
      }
      else
      {
        radiance = cv::Vec3f(0.30f, 0.25f, 0.20f);
      }
      if (glm::dot(d, sun) > cosSun)
      {
        radiance = cv::Vec3f(2000.0f, 1900.0f, 1750.0f);
      }
      panorama.at<cv::Vec3f>(row, column) = radiance;
    }
  }
  return panorama;
}

// Adds a disk-shaped lamp of warm white light (chromaticity of a 3000 K lamp, normalised to
// luminance 1 x radiance) to a linear panorama. Each texel is covered by 4 x 4 subsamples so
// that the disk's edge is antialiased.
void AddLamp(cv::Mat& panorama, const Options& options, float radiance)
{
  const double azimuth = options.LampAzimuth * CV_PI / 180.0;
  const double elevation = options.LampElevation * CV_PI / 180.0;
  const glm::vec3 lamp(static_cast<float>(std::sin(azimuth) * std::cos(elevation)),
    static_cast<float>(std::sin(elevation)),
    static_cast<float>(-std::cos(azimuth) * std::cos(elevation)));
  const float cosRadius = static_cast<float>(std::cos(options.LampRadiusDegrees * CV_PI / 180.0));
  const cv::Vec3f colour(1.25f, 0.96f, 0.66f); // Rec. 709 luminance 1.0
  constexpr int sub = 4;
  for (int row = 0; row < panorama.rows; ++row)
  {
    for (int column = 0; column < panorama.cols; ++column)
    {
      int inside = 0;
      for (int sy = 0; sy < sub; ++sy)
      {
        for (int sx = 0; sx < sub; ++sx)
        {
          const glm::vec3 d =
            hv::equirectangularToDirection(glm::vec2((column + (sx + 0.5f) / sub) / panorama.cols,
              (row + (sy + 0.5f) / sub) / panorama.rows));
          inside += glm::dot(d, lamp) > cosRadius ? 1 : 0;
        }
      }
      if (inside > 0)
      {
        panorama.at<cv::Vec3f>(row, column) += colour * (radiance * inside / (sub * sub));
      }
    }
  }
}

// The largest of R, G, B of each pixel where mask is set.
// Where the output goes, and how.
struct Writer
{
  cv::VideoWriter Video;
  std::string Pattern; // numbered images when not empty
  std::string Path;
  std::string Description;

  void open(const Options& options)
  {
    std::string path = options.Output;
    const fs::path parent = fs::path(path).parent_path();
    if (!parent.empty())
    {
      std::error_code error;
      fs::create_directories(parent, error);
    }
    if (hv::lighting::PanoramaFrameGrabber::classifySource(path) ==
      hv::lighting::PanoramaSourceKind::ImageSequence)
    {
      this->Pattern = path;
      this->Path = path;
      this->Description = "numbered images";
      return;
    }
    std::string extension = fs::path(path).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
      [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (extension != ".mp4" && extension != ".mkv" && extension != ".avi")
    {
      Fail("--output '" + path +
        "' must end in .mp4, .mkv or .avi, or be a numbered image pattern such as "
        "frames/theta_%04d.png");
    }
    if (extension != ".avi")
    {
      // H.264, what 360-degree cameras stream; needs an H.264 encoder in FFmpeg (libx264 or
      // libopenh264).
      this->Video.open(path, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('a', 'v', 'c', '1'),
        options.FramesPerSecond, options.FrameSize);
      if (this->Video.isOpened())
      {
        this->Path = path;
        this->Description = "H.264";
        return;
      }
      std::fprintf(stderr,
        "holovolume-simulate-camera: FFmpeg cannot encode H.264 here (no libx264/openh264); "
        "writing Motion JPEG into an .avi instead\n");
      path = (fs::path(path).replace_extension(".avi")).string();
    }
    this->Video.open(path, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
      options.FramesPerSecond, options.FrameSize);
    if (!this->Video.isOpened())
    {
      Fail("cannot write the video '" + path +
        "': check that its folder is writable and that OpenCV has its FFmpeg backend, or write "
        "numbered images (--output frames/theta_%04d.png)");
    }
    this->Path = path;
    this->Description = "Motion JPEG";
  }

  // frame: CV_8UC3 RGB.
  void write(const cv::Mat& frame, int index)
  {
    cv::Mat bgr;
    cv::cvtColor(frame, bgr, cv::COLOR_RGB2BGR);
    if (!this->Pattern.empty())
    {
      std::vector<char> name(this->Pattern.size() + 32);
      std::snprintf(name.data(), name.size(), this->Pattern.c_str(), index);
      if (!cv::imwrite(name.data(), bgr))
      {
        Fail(std::string("cannot write '") + name.data() +
          "': check the folder and the extension (.png, .jpg)");
      }
    }
    else
    {
      this->Video.write(bgr);
    }
  }
};

// An equirectangular camera (one that stitches in the camera and streams panoramas) turned
// by yawDegrees to its left: the room moves right in its panorama by yaw / 360 of the width
// (u grows towards +X, hv/Equirectangular.h), a horizontal wrap-around shift (cv::remap with
// BORDER_WRAP), then the panorama is resampled to the frame size (cv::resize, INTER_AREA).
cv::Mat FilmEquirectangular(const cv::Mat& panorama, double yawDegrees, const cv::Size& frameSize)
{
  cv::Mat turned;
  if (yawDegrees != 0.0)
  {
    const float shift = static_cast<float>(yawDegrees / 360.0 * panorama.cols);
    cv::Mat mapX(panorama.size(), CV_32FC1), mapY(panorama.size(), CV_32FC1);
    for (int row = 0; row < panorama.rows; ++row)
    {
      for (int column = 0; column < panorama.cols; ++column)
      {
        mapX.at<float>(row, column) = column - shift;
        mapY.at<float>(row, column) = static_cast<float>(row);
      }
    }
    cv::remap(panorama, turned, mapX, mapY, cv::INTER_LINEAR, cv::BORDER_WRAP);
  }
  else
  {
    turned = panorama;
  }
  cv::Mat frame;
  cv::resize(turned, frame, frameSize, 0.0, 0.0,
    frameSize.width < panorama.cols ? cv::INTER_AREA : cv::INTER_LINEAR);
  return frame;
}
}

int main(int argc, char* argv[])
{
  Options options = ParseArguments(argc, argv);
  try
  {
    // The camera: calibrated dual-fisheye lenses, or an equirectangular camera.
    const bool equirectangular = options.Camera == "equirectangular";
    hv::lighting::FisheyeCalibration calibration;
    if (equirectangular)
    {
      if (options.FrameSize.empty())
      {
        options.FrameSize = cv::Size(1024, 512);
      }
      if (options.FrameSize.width != 2 * options.FrameSize.height)
      {
        Fail("--frame-size of an equirectangular camera must be twice as wide as high");
      }
    }
    else
    {
      if (fs::exists(options.Camera))
      {
        calibration = hv::lighting::loadCalibration(options.Camera);
      }
      else
      {
        const auto names = hv::lighting::calibrationPresetNames();
        if (std::find(names.begin(), names.end(), options.Camera) == names.end())
        {
          std::string known;
          for (const std::string& name : names)
          {
            known += name + ", ";
          }
          Fail("--camera '" + options.Camera + "' is neither a preset (" + known +
            "equirectangular) nor a calibration JSON file");
        }
        calibration = hv::lighting::presetCalibration(options.Camera);
      }
      if (options.FrameSize.empty())
      {
        options.FrameSize = cv::Size(calibration.FrameWidth, calibration.FrameHeight);
      }
      if (static_cast<long long>(options.FrameSize.width) * calibration.FrameHeight !=
        static_cast<long long>(options.FrameSize.height) * calibration.FrameWidth)
      {
        Fail("--frame-size " + std::to_string(options.FrameSize.width) + "x" +
          std::to_string(options.FrameSize.height) + " does not have the aspect ratio of the " +
          "calibration's " + std::to_string(calibration.FrameWidth) + "x" +
          std::to_string(calibration.FrameHeight) + " frames");
      }
    }
    // The linear frame the camera records of a (glared) panorama, turned by yaw degrees to its
    // left; for the dual-fisheye camera both lenses turn about the camera's +Y axis.
    auto film = [&](const cv::Mat& panorama, double yaw, int supersampling)
    {
      if (equirectangular)
      {
        return FilmEquirectangular(panorama, yaw, options.FrameSize);
      }
      hv::lighting::FisheyeCalibration turned = calibration;
      turned.Front.YawDegrees += yaw;
      turned.Back.YawDegrees += yaw;
      return hv::lighting::renderDualFisheye(panorama, turned, options.FrameSize, supersampling);
    };

    cv::Mat room;
    if (options.Environment == "synthetic")
    {
      room = SyntheticEnvironment();
    }
    else
    {
      if (!fs::exists(options.Environment))
      {
        Fail("environment '" + options.Environment + "' not found" +
          (options.Environment == DefaultEnvironment
              ? "; install it with: apt-get install blender-data, or use --environment synthetic"
              : ""));
      }
      hv::lighting::PanoramaFrame read =
        hv::lighting::PanoramaFrameGrabber::readImage(options.Environment);
      if (read.Image.cols != 2 * read.Image.rows)
      {
        Fail("environment '" + options.Environment + "' is " + std::to_string(read.Image.cols) +
          "x" + std::to_string(read.Image.rows) +
          "; an equirectangular panorama is twice as wide as high");
      }
      if (read.Encoding == hv::lighting::PixelEncoding::SceneLinear)
      {
        room = read.Image;
      }
      else
      {
        // An LDR panorama is linearised (sRGB): the result has no radiance above the clip level.
        std::fprintf(stderr,
          "holovolume-simulate-camera: '%s' is a display-referred (LDR) image; its lights are "
          "clipped, prefer an HDR panorama (.exr, .hdr)\n",
          options.Environment.c_str());
        hv::lighting::CameraResponse().linearize(read.Image, room);
      }
    }

    const auto startAll = Clock::now();
    // The room as the lens sees it, without and with the lamp: the lens PSF is applied once
    // per state; turning the camera is a change of the lens orientation in film().
    cv::Mat filmedRoom, filmedRoomWithLamp;
    hv::lighting::applyLensGlare(room, filmedRoom, hv::lighting::LensGlare());

    // Exposure: the radiance at which the brightest ClipPercent of the pixels inside the image
    // circles (of frame 0, lamp off) reach the clip level.
    const auto firstRender = Clock::now();
    cv::Mat linearFrame = film(filmedRoom, 0.0, options.Supersampling);
    double renderMilliseconds =
      std::chrono::duration<double, std::milli>(Clock::now() - firstRender).count();
    int renders = 1;
    const cv::Mat circles = film(cv::Mat(8, 16, CV_32FC3, cv::Scalar::all(1.0)), 0.0, 1);
    cv::Mat insideCircles;
    cv::extractChannel(circles, insideCircles, 0);
    insideCircles = insideCircles > 0.0f;
    if (cv::countNonZero(insideCircles) == 0)
    {
      Fail("the calibration's image circles do not cover any pixel of the frame");
    }
    const float exposure =
      hv::lighting::exposureForClippedPercent(linearFrame, options.ClipPercent, insideCircles);

    if (options.LightSwitchFrame >= 0 && options.LightSwitchFrame < options.Frames)
    {
      cv::Mat roomWithLamp = room.clone();
      AddLamp(roomWithLamp, options, static_cast<float>(options.LampBrightness / exposure));
      hv::lighting::applyLensGlare(roomWithLamp, filmedRoomWithLamp, hv::lighting::LensGlare());
    }

    Writer writer;
    writer.open(options);
    std::printf("Environment  %s (%dx%d)\n", options.Environment.c_str(), room.cols, room.rows);
    std::printf("Camera       %s, %dx%d frames, %.4g fps\n", options.Camera.c_str(),
      options.FrameSize.width, options.FrameSize.height, options.FramesPerSecond);
    std::printf("Exposure     x%.4g (radiance %.4g clips)\n", exposure, 1.0 / exposure);

    hv::lighting::CameraResponse response;
    cv::Mat frame8, noise, noisy;
    double lastYaw = 0.0;
    bool lastLamp = false;
    for (int frame = 0; frame < options.Frames; ++frame)
    {
      const double yaw = std::remainder(options.RotateDegreesPerFrame * frame, 360.0);
      const bool lamp = options.LightSwitchFrame >= 0 && frame >= options.LightSwitchFrame;
      if (yaw != lastYaw || lamp != lastLamp)
      {
        const auto start = Clock::now();
        linearFrame = film(lamp ? filmedRoomWithLamp : filmedRoom, yaw, options.Supersampling);
        renderMilliseconds +=
          std::chrono::duration<double, std::milli>(Clock::now() - start).count();
        ++renders;
        lastYaw = yaw;
        lastLamp = lamp;
      }
      response.encode(linearFrame * exposure, frame8);
      if (frame == 0)
      {
        cv::Mat maxChannel;
        cv::Mat channels[3];
        cv::split(frame8, channels);
        maxChannel = cv::max(channels[0], cv::max(channels[1], channels[2]));
        const double clipped = cv::countNonZero((maxChannel == 255) & insideCircles) * 100.0 /
          cv::countNonZero(insideCircles);
        std::printf("Clipped      %.2f %% of the pixels that see the room (frame 0)\n", clipped);
      }
      if (options.Noise > 0.0)
      {
        cv::RNG rng(static_cast<std::uint64_t>(options.Seed) * 1000003ULL + frame + 1);
        noise.create(frame8.size(), CV_16SC3);
        rng.fill(noise, cv::RNG::NORMAL, cv::Scalar::all(0.0), cv::Scalar::all(options.Noise));
        frame8.convertTo(noisy, CV_16SC3);
        noisy += noise;
        noisy.convertTo(frame8, CV_8UC3); // saturates to [0, 255]
      }
      writer.write(frame8, frame);
    }
    const double seconds = std::chrono::duration<double>(Clock::now() - startAll).count();
    std::printf("Wrote        %s (%s, %d frames%s%s) in %.2f s; %.0f ms per rendered frame\n",
      writer.Path.c_str(), writer.Description.c_str(), options.Frames,
      options.RotateDegreesPerFrame != 0.0 ? ", turning" : "",
      options.LightSwitchFrame >= 0 && options.LightSwitchFrame < options.Frames
        ? (", lamp on from frame " + std::to_string(options.LightSwitchFrame)).c_str()
        : "",
      seconds, renderMilliseconds / renders);
  }
  catch (const std::exception& error)
  {
    Fail(error.what());
  }
  return EXIT_SUCCESS;
}
