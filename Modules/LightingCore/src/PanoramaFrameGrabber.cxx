// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/PanoramaFrameGrabber.h"

#include <OpenImageIO/imageio.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <opencv2/videoio/registry.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <utility>

namespace hv
{
namespace lighting
{
namespace
{
using SteadyClock = std::chrono::steady_clock;

double steadySeconds()
{
  return std::chrono::duration<double>(SteadyClock::now().time_since_epoch()).count();
}

SteadyClock::duration secondsToDuration(double seconds)
{
  return std::chrono::duration_cast<SteadyClock::duration>(
    std::chrono::duration<double>(std::max(seconds, 0.0)));
}

std::string lowerExtension(const std::string& path)
{
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
    [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

// Scene-linear formats go through OpenImageIO, which reads every EXR compression and the
// Radiance RGBE encoding as float; OpenCV's own EXR support is optional in its builds.
bool isSceneLinearExtension(const std::string& extension)
{
  return extension == ".exr" || extension == ".hdr" || extension == ".pic" || extension == ".pfm";
}

bool isImageExtension(const std::string& extension)
{
  static const char* const extensions[] = { ".png", ".jpg", ".jpeg", ".jpe", ".tif", ".tiff",
    ".bmp", ".dib", ".webp", ".ppm", ".pgm", ".pbm", ".pnm", ".pxm", ".jp2", ".sr", ".ras" };
  return isSceneLinearExtension(extension) ||
    std::find(std::begin(extensions), std::end(extensions), extension) != std::end(extensions);
}

bool isLiveKind(PanoramaSourceKind kind)
{
  return kind == PanoramaSourceKind::Device || kind == PanoramaSourceKind::NetworkStream;
}

// A printf pattern with exactly one integer conversion, split around it. OpenCV's
// VideoCapture reads such sequences too (CAP_IMAGES), but converts every image to 8-bit BGR
// and reads neither 16-bit nor EXR through OpenImageIO, so the names are formatted here.
struct SequencePattern
{
  std::string Prefix;
  std::string Suffix;
  int Width = 0;
  bool ZeroPad = false;

  std::string name(int number) const
  {
    std::string digits = std::to_string(number);
    if (static_cast<int>(digits.size()) < this->Width)
    {
      digits.insert(
        0, static_cast<std::size_t>(this->Width) - digits.size(), this->ZeroPad ? '0' : ' ');
    }
    return this->Prefix + digits + this->Suffix;
  }
};

// Parses "%d", "%4d" or "%04d" (and "%%" as a literal percent sign); returns false if the
// string has no conversion. Throws for other or several conversions.
bool parseSequencePattern(const std::string& source, SequencePattern* pattern)
{
  SequencePattern parsed;
  bool found = false;
  std::string* target = &parsed.Prefix;
  for (std::size_t i = 0; i < source.size(); ++i)
  {
    if (source[i] != '%')
    {
      *target += source[i];
      continue;
    }
    if (i + 1 < source.size() && source[i + 1] == '%')
    {
      *target += '%';
      ++i;
      continue;
    }
    std::size_t j = i + 1;
    bool zeroPad = false;
    if (j < source.size() && source[j] == '0')
    {
      zeroPad = true;
      ++j;
    }
    int width = 0;
    while (j < source.size() && std::isdigit(static_cast<unsigned char>(source[j])))
    {
      width = 10 * width + (source[j] - '0');
      ++j;
    }
    if (j >= source.size() || source[j] != 'd' || found || width > 32)
    {
      throw std::invalid_argument("Image sequence pattern '" + source +
        "' is not supported: use exactly one integer conversion such as %d, %4d or %04d "
        "(write %% for a literal percent sign).");
    }
    found = true;
    parsed.Width = width;
    parsed.ZeroPad = zeroPad;
    target = &parsed.Suffix;
    i = j;
  }
  if (found && pattern)
  {
    *pattern = parsed;
  }
  return found;
}

const char* depthName(int depth)
{
  switch (depth)
  {
    case CV_8U:
      return "8-bit unsigned";
    case CV_8S:
      return "8-bit signed";
    case CV_16U:
      return "16-bit unsigned";
    case CV_16S:
      return "16-bit signed";
    case CV_32S:
      return "32-bit signed";
    case CV_32F:
      return "32-bit float";
    case CV_64F:
      return "64-bit float";
    default:
      return "16-bit float";
  }
}

PanoramaFrame readSceneLinearImage(const std::string& path, bool replaceNonFiniteValues)
{
  auto input = OIIO::ImageInput::open(path);
  if (!input)
  {
    throw std::runtime_error("Cannot open image '" + path + "' with OpenImageIO: " +
      OIIO::geterror() + ". Check that the file is a complete EXR, HDR or PFM image.");
  }
  const OIIO::ImageSpec& spec = input->spec();
  const int channels = spec.nchannels;
  if (channels > 4)
  {
    // Multi-layer EXRs list further channels after R, G, B; accept them only when the first
    // three are named so, rather than guessing which layer is the radiance.
    auto endsWith = [&](int c, char letter)
    {
      const std::string& name = spec.channelnames[static_cast<std::size_t>(c)];
      return !name.empty() && std::toupper(static_cast<unsigned char>(name.back())) == letter;
    };
    if (!(endsWith(0, 'R') && endsWith(1, 'G') && endsWith(2, 'B')))
    {
      throw std::runtime_error("Image '" + path + "' has " + std::to_string(channels) +
        " channels and the first three are not R, G, B: export the radiance layer alone "
        "(RGB or RGBA).");
    }
  }
  // Read R, G, B (or the single grey channel) straight into the frame, leaving alpha and
  // further channels unread.
  const int read = channels >= 3 ? 3 : 1;
  cv::Mat image(spec.height, spec.width, CV_32FC(read));
  if (!input->read_image(0, 0, 0, read, OIIO::TypeDesc::FLOAT, image.data))
  {
    throw std::runtime_error(
      "Reading image '" + path + "' failed: " + input->geterror() + ". The file may be damaged.");
  }
  input->close();
  PanoramaFrame frame;
  frame.Encoding = PixelEncoding::SceneLinear;
  if (read == 1)
  {
    cv::cvtColor(image, frame.Image, cv::COLOR_GRAY2RGB);
  }
  else
  {
    frame.Image = image; // OpenImageIO already delivers R, G, B order
  }
  PanoramaFrameGrabber::sanitizeSceneLinear(frame.Image, replaceNonFiniteValues, "'" + path + "'");
  return frame;
}

// Reads the next frame into a buffer of the capture thread's pool; false at the end of the
// source or when the read failed, with the reason in error.
class FrameReader
{
public:
  virtual ~FrameReader() = default;
  virtual bool read(cv::Mat& rgb, PixelEncoding& encoding, std::string& error) = 0;
  // Goes back to the first frame; false where that is not possible.
  virtual bool rewind() = 0;
  virtual double frameRate() const = 0;
};

class CaptureReader final : public FrameReader
{
public:
  CaptureReader(
    const std::string& source, PanoramaSourceKind kind, const PanoramaFrameGrabberOptions& options)
    : Source(source)
    , Kind(kind)
    , Options(options)
  {
    this->open();
  }

  bool read(cv::Mat& rgb, PixelEncoding& encoding, std::string& error) override
  {
    if (!this->Capture.read(this->Decoded) || this->Decoded.empty())
    {
      std::ostringstream message;
      if (this->Kind == PanoramaSourceKind::VideoFile)
      {
        message << "end of video '" << this->Source << "' (or a frame that could not be decoded)";
      }
      else
      {
        message << (this->Kind == PanoramaSourceKind::Device ? "camera '" : "stream '")
                << this->Source << "' ended, failed or sent nothing for "
                << this->Options.ReadTimeout << " s";
      }
      error = message.str();
      return false;
    }
    PanoramaFrameGrabber::convertToRgb(this->Decoded, rgb, "'" + this->Source + "'");
    encoding = rgb.depth() == CV_32F ? PixelEncoding::SceneLinear : PixelEncoding::DisplayReferred;
    if (encoding == PixelEncoding::SceneLinear)
    {
      PanoramaFrameGrabber::sanitizeSceneLinear(
        rgb, this->Options.ReplaceNonFiniteValues, "'" + this->Source + "'");
    }
    return true;
  }

  bool rewind() override
  {
    if (this->Kind != PanoramaSourceKind::VideoFile)
    {
      return false;
    }
    if (this->Capture.set(cv::CAP_PROP_POS_FRAMES, 0.0))
    {
      return true;
    }
    // Some containers cannot seek; opening the file again always starts at its beginning.
    try
    {
      this->open();
      return true;
    }
    catch (const std::exception&)
    {
      return false;
    }
  }

  double frameRate() const override
  {
    const double rate = this->Capture.get(cv::CAP_PROP_FPS);
    return std::isfinite(rate) && rate > 0.0 ? rate : 0.0;
  }

private:
  void open()
  {
    this->Capture.release();
    if (this->Kind == PanoramaSourceKind::Device)
    {
      const bool isIndex = std::all_of(this->Source.begin(), this->Source.end(),
        [](unsigned char c) { return std::isdigit(c) != 0; });
      if (isIndex && this->Source.size() > 4)
      {
        throw std::invalid_argument("Camera index '" + this->Source +
          "' is out of range: use a small index such as 0, or /dev/videoN. (To open a file "
          "whose name is a number, write it as ./" +
          this->Source + ".)");
      }
      if (isIndex)
      {
        this->Capture.open(std::stoi(this->Source), cv::CAP_ANY);
      }
      else
      {
        this->Capture.open(this->Source, cv::CAP_V4L2);
      }
      if (!this->Capture.isOpened())
      {
        throw std::runtime_error("Cannot open camera '" + this->Source +
          "': check that the device exists (ls /dev/video*), that this user may read it (group "
          "'video') and that no other program holds it.");
      }
      return;
    }
    if (!cv::videoio_registry::hasBackend(cv::CAP_FFMPEG))
    {
      throw std::runtime_error("Cannot open '" + this->Source +
        "': this OpenCV has no FFmpeg video backend; install an OpenCV built with FFmpeg.");
    }
    const std::vector<int> parameters = { cv::CAP_PROP_OPEN_TIMEOUT_MSEC,
      static_cast<int>(std::lround(1000.0 * this->Options.OpenTimeout)),
      cv::CAP_PROP_READ_TIMEOUT_MSEC,
      static_cast<int>(std::lround(1000.0 * this->Options.ReadTimeout)) };
    this->Capture.open(this->Source, cv::CAP_FFMPEG, parameters);
    if (this->Capture.isOpened())
    {
      return;
    }
    if (this->Kind == PanoramaSourceKind::NetworkStream)
    {
      std::ostringstream message;
      message << "Cannot open network stream '" << this->Source << "' within "
              << this->Options.OpenTimeout
              << " s: check the URL (scheme, host, port, path), that the camera or server is "
                 "running and reachable from here, and that its codec is one FFmpeg decodes "
                 "(H.264, MJPEG, ...).";
      throw std::runtime_error(message.str());
    }
    throw std::runtime_error("OpenCV's FFmpeg backend cannot open video file '" + this->Source +
      "': check that it is a complete video in a container and codec FFmpeg reads (H.264 in "
      "MP4/MKV/TS, MJPEG in AVI, ...).");
  }

  std::string Source;
  PanoramaSourceKind Kind;
  PanoramaFrameGrabberOptions Options;
  cv::VideoCapture Capture;
  cv::Mat Decoded; // reused by VideoCapture::read, so decoding allocates once
};

// Still images (one frame) and numbered image sequences.
class ImageReader final : public FrameReader
{
public:
  ImageReader(
    const std::string& source, PanoramaSourceKind kind, const PanoramaFrameGrabberOptions& options)
    : Source(source)
    , Options(options)
  {
    namespace fs = std::filesystem;
    if (kind == PanoramaSourceKind::ImageFile)
    {
      if (!fs::is_regular_file(source))
      {
        throw std::runtime_error("Image file '" + source + "' does not exist: check the path" +
          (fs::path(source).is_relative()
              ? " (relative to the working directory '" + fs::current_path().string() + "')."
              : "."));
      }
      this->Single = true;
      return;
    }
    parseSequencePattern(source, &this->Pattern);
    // Like OpenCV's CAP_IMAGES, the sequence starts at the lowest existing number; it ends at
    // the first missing one after that.
    constexpr int LastFirstNumber = 9999;
    for (int number = 0; number <= LastFirstNumber; ++number)
    {
      if (fs::is_regular_file(this->Pattern.name(number)))
      {
        this->First = number;
        this->Next = number;
        return;
      }
    }
    throw std::runtime_error("No image matches the sequence pattern '" + source +
      "' for numbers 0 to " + std::to_string(LastFirstNumber) +
      ": check the directory and the pattern (printf style, e.g. pano_%04d.png for "
      "pano_0001.png).");
  }

  bool read(cv::Mat& rgb, PixelEncoding& encoding, std::string& error) override
  {
    std::string path;
    if (this->Single)
    {
      if (this->Next > 0)
      {
        error = "a still image is a single frame";
        return false;
      }
      path = this->Source;
    }
    else
    {
      path = this->Pattern.name(this->Next);
      if (!std::filesystem::is_regular_file(path))
      {
        error = "end of image sequence '" + this->Source + "' (no '" + path + "')";
        return false;
      }
    }
    PanoramaFrame frame =
      PanoramaFrameGrabber::readImage(path, this->Options.ReplaceNonFiniteValues);
    rgb = frame.Image; // the decoder allocated it; no copy into the pool buffer
    encoding = frame.Encoding;
    ++this->Next;
    return true;
  }

  bool rewind() override
  {
    if (this->Single)
    {
      return false;
    }
    this->Next = this->First;
    return true;
  }

  double frameRate() const override { return 0.0; }

private:
  std::string Source;
  PanoramaFrameGrabberOptions Options;
  SequencePattern Pattern;
  bool Single = false;
  int First = 0;
  int Next = 0;
};

std::unique_ptr<FrameReader> openReader(
  const std::string& source, PanoramaSourceKind kind, const PanoramaFrameGrabberOptions& options)
{
  if (kind == PanoramaSourceKind::ImageFile || kind == PanoramaSourceKind::ImageSequence)
  {
    return std::make_unique<ImageReader>(source, kind, options);
  }
  if (kind == PanoramaSourceKind::VideoFile && !std::filesystem::is_regular_file(source))
  {
    throw std::runtime_error("Video file '" + source + "' does not exist: check the path" +
      (std::filesystem::path(source).is_relative() ? " (relative to the working directory '" +
            std::filesystem::current_path().string() + "')."
                                                   : "."));
  }
  return std::make_unique<CaptureReader>(source, kind, options);
}

// A buffer the capture thread may overwrite: one that only the pool references. Frames handed
// out share their buffer (cv::Mat reference counting), so a buffer a consumer still holds is
// never written to; CV_XADD(.., 0) is OpenCV's atomic read of the count.
cv::Mat& acquireBuffer(std::array<cv::Mat, 3>& pool)
{
  for (cv::Mat& buffer : pool)
  {
    if (!buffer.u || CV_XADD(&buffer.u->refcount, 0) == 1)
    {
      return buffer;
    }
  }
  // Every buffer is still held elsewhere: give one up to its holders and allocate anew.
  pool[0].release();
  return pool[0];
}
}

const char* toString(PanoramaSourceKind kind)
{
  switch (kind)
  {
    case PanoramaSourceKind::VideoFile:
      return "VideoFile";
    case PanoramaSourceKind::Device:
      return "Device";
    case PanoramaSourceKind::NetworkStream:
      return "NetworkStream";
    case PanoramaSourceKind::ImageFile:
      return "ImageFile";
    case PanoramaSourceKind::ImageSequence:
      return "ImageSequence";
  }
  return "Unknown";
}

const char* toString(PixelEncoding encoding)
{
  return encoding == PixelEncoding::SceneLinear ? "SceneLinear" : "DisplayReferred";
}

struct PanoramaFrameGrabber::Internals
{
  PanoramaFrameGrabberOptions Options;
  std::string Source;
  PanoramaSourceKind Kind = PanoramaSourceKind::VideoFile;
  std::thread Thread;

  // Guards everything below; held only for header copies and counter updates.
  mutable std::mutex Mutex;
  std::condition_variable FrameArrived; // also signalled when the source finishes
  std::condition_variable FrameTaken;   // DeliverEveryFrame: the newest frame was handed out
  std::condition_variable StopSignal;
  bool StopRequested = false;
  PanoramaFrame Newest;
  std::int64_t DeliveredIndex = -1;
  PanoramaFrameGrabberStatus Status;

  PanoramaFrame takeLocked()
  {
    if (this->Newest.Index > this->DeliveredIndex)
    {
      this->DeliveredIndex = this->Newest.Index;
      ++this->Status.FramesDelivered;
      this->FrameTaken.notify_all();
    }
    return this->Newest;
  }

  void publish(const cv::Mat& image, PixelEncoding encoding, std::int64_t index)
  {
    PanoramaFrame frame;
    frame.Image = image;
    frame.Encoding = encoding;
    frame.Index = index;
    frame.Timestamp = steadySeconds();
    {
      std::lock_guard<std::mutex> lock(this->Mutex);
      if (this->Newest.Index > this->DeliveredIndex)
      {
        ++this->Status.FramesDropped;
      }
      this->Newest = std::move(frame);
      ++this->Status.FramesReceived;
      this->Status.Connected = true;
    }
    this->FrameArrived.notify_all();
  }

  void report(const std::string& error, bool connected, bool finished)
  {
    {
      std::lock_guard<std::mutex> lock(this->Mutex);
      this->Status.LastError = error;
      this->Status.Connected = connected;
      this->Status.Finished = this->Status.Finished || finished;
    }
    if (finished)
    {
      this->FrameArrived.notify_all();
    }
  }

  // Waits until deadline; false when close() asked the thread to stop.
  bool sleepUntil(SteadyClock::time_point deadline)
  {
    std::unique_lock<std::mutex> lock(this->Mutex);
    return !this->StopSignal.wait_until(lock, deadline, [this] { return this->StopRequested; });
  }

  // Waits until the newest frame was handed out; false when close() asked the thread to stop.
  bool waitUntilTaken()
  {
    std::unique_lock<std::mutex> lock(this->Mutex);
    this->FrameTaken.wait(
      lock, [this] { return this->StopRequested || this->Newest.Index <= this->DeliveredIndex; });
    return !this->StopRequested;
  }

  bool stopRequested() const
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    return this->StopRequested;
  }

  void capture(std::unique_ptr<FrameReader> reader, PanoramaFrameGrabberOptions options,
    std::int64_t nextIndex);
};

// The capture thread. It works on its own copy of the options, so setOptions() during a
// capture affects only the next open().
void PanoramaFrameGrabber::Internals::capture(
  std::unique_ptr<FrameReader> reader, PanoramaFrameGrabberOptions options, std::int64_t nextIndex)
{
  const bool live = isLiveKind(this->Kind);
  const bool paced = options.PaceToFrameRate && !live;
  const bool everyFrame = options.DeliverEveryFrame && !live;
  const double rate = reader->frameRate() > 0.0 ? reader->frameRate() : options.DefaultFrameRate;
  const SteadyClock::duration period = secondsToDuration(1.0 / std::max(rate, 1e-3));
  SteadyClock::time_point deadline = SteadyClock::now() + period;
  double reconnectDelay = options.ReconnectInitialDelay;
  int failedAttempts = 0;
  bool justRewound = false;
  std::array<cv::Mat, 3> pool;

  while (!this->stopRequested())
  {
    if (!reader)
    {
      // A live source dropped: reopen it, waiting longer after each failure.
      if (!this->sleepUntil(SteadyClock::now() + secondsToDuration(reconnectDelay)))
      {
        break;
      }
      {
        std::lock_guard<std::mutex> lock(this->Mutex);
        ++this->Status.ReconnectAttempts;
      }
      try
      {
        reader = openReader(this->Source, this->Kind, options);
        std::lock_guard<std::mutex> lock(this->Mutex);
        ++this->Status.Reconnects;
        reconnectDelay = options.ReconnectInitialDelay;
        failedAttempts = 0;
      }
      catch (const std::exception& e)
      {
        ++failedAttempts;
        reconnectDelay = std::min(2.0 * reconnectDelay, options.ReconnectMaxDelay);
        const bool giveUp =
          options.MaxReconnectAttempts > 0 && failedAttempts >= options.MaxReconnectAttempts;
        this->report(giveUp ? std::string(e.what()) + " Gave up after " +
              std::to_string(failedAttempts) + " reconnect attempts."
                            : std::string(e.what()),
          false, giveUp);
        if (giveUp)
        {
          break;
        }
        continue;
      }
    }

    if (everyFrame && !this->waitUntilTaken())
    {
      break;
    }
    if (paced)
    {
      if (!this->sleepUntil(deadline))
      {
        break;
      }
      // After a stall (a slow disk, a suspended process) continue at the nominal rate
      // instead of bursting to catch up.
      deadline = std::max(deadline + period, SteadyClock::now());
    }

    cv::Mat& buffer = acquireBuffer(pool);
    PixelEncoding encoding = PixelEncoding::DisplayReferred;
    std::string error;
    bool ok = false;
    try
    {
      ok = reader->read(buffer, encoding, error);
    }
    catch (const std::exception& e)
    {
      error = e.what();
    }
    if (ok)
    {
      justRewound = false;
      this->publish(buffer, encoding, nextIndex++);
      continue;
    }

    if (live)
    {
      reader.reset();
      if (!options.Reconnect)
      {
        this->report(error + "; reconnecting is off.", false, true);
        break;
      }
      this->report(error + "; reconnecting.", false, false);
      continue;
    }
    // A file: loop if asked, unless the very first frame after a rewind failed too (the file
    // changed or vanished), which would otherwise spin forever.
    if (options.Loop && !justRewound && reader->rewind())
    {
      justRewound = true;
      // The read that found the end used up a frame period; the first frame is due now.
      deadline = SteadyClock::now();
      continue;
    }
    this->report(error, false, true);
    break;
  }
}

PanoramaFrameGrabber::PanoramaFrameGrabber()
  : Impl(std::make_unique<Internals>())
{
}

PanoramaFrameGrabber::PanoramaFrameGrabber(const PanoramaFrameGrabberOptions& options)
  : Impl(std::make_unique<Internals>())
{
  this->Impl->Options = options;
}

PanoramaFrameGrabber::~PanoramaFrameGrabber()
{
  this->close();
}

void PanoramaFrameGrabber::setOptions(const PanoramaFrameGrabberOptions& options)
{
  this->Impl->Options = options;
}

const PanoramaFrameGrabberOptions& PanoramaFrameGrabber::options() const
{
  return this->Impl->Options;
}

PanoramaSourceKind PanoramaFrameGrabber::classifySource(const std::string& source)
{
  if (source.find("://") != std::string::npos)
  {
    return PanoramaSourceKind::NetworkStream;
  }
  if (source.rfind("/dev/video", 0) == 0 ||
    (!source.empty() &&
      std::all_of(source.begin(), source.end(), [](unsigned char c) { return std::isdigit(c); })))
  {
    return PanoramaSourceKind::Device;
  }
  if (parseSequencePattern(source, nullptr))
  {
    return PanoramaSourceKind::ImageSequence;
  }
  if (isImageExtension(lowerExtension(source)))
  {
    return PanoramaSourceKind::ImageFile;
  }
  return PanoramaSourceKind::VideoFile;
}

void PanoramaFrameGrabber::open(const std::string& source)
{
  this->close();
  if (source.empty())
  {
    throw std::invalid_argument("No panorama source given: pass a video file, an image file or "
                                "sequence pattern, a camera (/dev/video0 or 0) or a stream URL.");
  }
  const PanoramaFrameGrabberOptions& options = this->Impl->Options;
  if (!(options.ReconnectInitialDelay >= 0.0 && options.ReconnectMaxDelay >= 0.0 &&
        options.OpenTimeout > 0.0 && options.ReadTimeout > 0.0 && options.DefaultFrameRate > 0.0))
  {
    throw std::invalid_argument("PanoramaFrameGrabber options out of range: reconnect delays "
                                "must be >= 0, timeouts and DefaultFrameRate > 0.");
  }
  const PanoramaSourceKind kind = classifySource(source);
  std::unique_ptr<FrameReader> reader = openReader(source, kind, options);

  // Decode the first frame here, so that a source that opens but cannot be decoded (an
  // unsupported codec, a damaged file, a camera that sends nothing) fails in open().
  cv::Mat first;
  PixelEncoding encoding = PixelEncoding::DisplayReferred;
  std::string error;
  if (!reader->read(first, encoding, error))
  {
    throw std::runtime_error("Opened '" + source + "' but could not read a frame (" + error +
      "): check the codec (FFmpeg must decode it), that the file is not empty or damaged, or "
      "that the camera or stream is sending.");
  }

  Internals& impl = *this->Impl;
  impl.Source = source;
  impl.Kind = kind;
  {
    std::lock_guard<std::mutex> lock(impl.Mutex);
    impl.StopRequested = false;
    impl.Newest = PanoramaFrame();
    impl.DeliveredIndex = -1;
    impl.Status = PanoramaFrameGrabberStatus();
    impl.Status.Open = true;
    impl.Status.FrameRate = reader->frameRate();
  }
  impl.publish(first, encoding, 0);
  impl.Thread = std::thread([&impl, options](std::unique_ptr<FrameReader> r)
    { impl.capture(std::move(r), options, 1); },
    std::move(reader));
}

void PanoramaFrameGrabber::close()
{
  Internals& impl = *this->Impl;
  {
    std::lock_guard<std::mutex> lock(impl.Mutex);
    impl.StopRequested = true;
  }
  impl.StopSignal.notify_all();
  impl.FrameArrived.notify_all();
  impl.FrameTaken.notify_all();
  if (impl.Thread.joinable())
  {
    impl.Thread.join();
  }
  std::lock_guard<std::mutex> lock(impl.Mutex);
  impl.Newest = PanoramaFrame(); // keep the counters readable, release the pixels
  impl.Status.Open = false;
  impl.Status.Connected = false;
}

bool PanoramaFrameGrabber::isOpen() const
{
  std::lock_guard<std::mutex> lock(this->Impl->Mutex);
  return this->Impl->Status.Open;
}

const std::string& PanoramaFrameGrabber::source() const
{
  return this->Impl->Source;
}

PanoramaSourceKind PanoramaFrameGrabber::sourceKind() const
{
  return this->Impl->Kind;
}

PanoramaFrame PanoramaFrameGrabber::latest()
{
  std::lock_guard<std::mutex> lock(this->Impl->Mutex);
  return this->Impl->takeLocked();
}

bool PanoramaFrameGrabber::tryGetNewFrame(PanoramaFrame& frame, std::int64_t lastIndex)
{
  std::lock_guard<std::mutex> lock(this->Impl->Mutex);
  if (this->Impl->Newest.Index <= lastIndex)
  {
    return false;
  }
  frame = this->Impl->takeLocked();
  return true;
}

bool PanoramaFrameGrabber::waitForFrame(
  PanoramaFrame& frame, std::int64_t lastIndex, double timeoutSeconds)
{
  Internals& impl = *this->Impl;
  std::unique_lock<std::mutex> lock(impl.Mutex);
  impl.FrameArrived.wait_until(lock, SteadyClock::now() + secondsToDuration(timeoutSeconds),
    [&]
    {
      return impl.Newest.Index > lastIndex || impl.StopRequested || impl.Status.Finished ||
        !impl.Status.Open;
    });
  if (impl.Newest.Index <= lastIndex)
  {
    return false;
  }
  frame = impl.takeLocked();
  return true;
}

PanoramaFrameGrabberStatus PanoramaFrameGrabber::status() const
{
  std::lock_guard<std::mutex> lock(this->Impl->Mutex);
  return this->Impl->Status;
}

PanoramaFrame PanoramaFrameGrabber::readImage(const std::string& path, bool replaceNonFiniteValues)
{
  if (!std::filesystem::is_regular_file(path))
  {
    throw std::runtime_error("Image file '" + path + "' does not exist: check the path.");
  }
  if (isSceneLinearExtension(lowerExtension(path)))
  {
    return readSceneLinearImage(path, replaceNonFiniteValues);
  }
  if (!cv::haveImageReader(path))
  {
    throw std::runtime_error("OpenCV has no reader for image '" + path +
      "': use PNG, JPEG, TIFF or another format OpenCV decodes, or EXR/HDR for HDR input.");
  }
  // ANYDEPTH keeps 16-bit and float samples, ANYCOLOR keeps greyscale as one channel and drops
  // alpha; both still apply the EXIF orientation.
  const cv::Mat decoded = cv::imread(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  if (decoded.empty())
  {
    throw std::runtime_error(
      "OpenCV could not decode image '" + path + "': the file may be truncated or damaged.");
  }
  PanoramaFrame frame;
  convertToRgb(decoded, frame.Image, "image '" + path + "'");
  frame.Encoding =
    frame.Image.depth() == CV_32F ? PixelEncoding::SceneLinear : PixelEncoding::DisplayReferred;
  if (frame.Encoding == PixelEncoding::SceneLinear)
  {
    sanitizeSceneLinear(frame.Image, replaceNonFiniteValues, "'" + path + "'");
  }
  return frame;
}

void PanoramaFrameGrabber::convertToRgb(
  const cv::Mat& decoded, cv::Mat& rgb, const std::string& what)
{
  const int depth = decoded.depth();
  if (depth != CV_8U && depth != CV_16U && depth != CV_32F)
  {
    throw std::runtime_error(what + " has " + depthName(depth) +
      " samples; panorama frames must be 8- or 16-bit unsigned or 32-bit float: convert it.");
  }
  switch (decoded.channels())
  {
    case 1:
      // Greyscale: the same value in R, G and B (a grey light stays grey).
      cv::cvtColor(decoded, rgb, cv::COLOR_GRAY2RGB);
      break;
    case 3:
      cv::cvtColor(decoded, rgb, cv::COLOR_BGR2RGB);
      break;
    case 4:
      cv::cvtColor(decoded, rgb, cv::COLOR_BGRA2RGB);
      break;
    default:
      throw std::runtime_error(what + " has " + std::to_string(decoded.channels()) +
        " channels; panorama frames need 1 (grey), 3 (colour) or 4 (colour and alpha).");
  }
}

SceneLinearRepair PanoramaFrameGrabber::sanitizeSceneLinear(
  cv::Mat& image, bool replaceNonFiniteValues, const std::string& what)
{
  if (image.depth() != CV_32F)
  {
    throw std::invalid_argument("sanitizeSceneLinear needs a 32-bit float image, " + what + " is " +
      depthName(image.depth()));
  }
  SceneLinearRepair repair;
  cv::Mat samples = image.reshape(1);
  // cv::checkRange finds NaN and infinities in one vectorised pass; the count and the
  // replacement below only run for the rare image that has some.
  if (!cv::checkRange(samples, true))
  {
    for (int row = 0; row < samples.rows; ++row)
    {
      float* value = samples.ptr<float>(row);
      for (int i = 0; i < samples.cols; ++i)
      {
        if (!std::isfinite(value[i]))
        {
          ++repair.NonFiniteValues;
          value[i] = 0.0f;
        }
      }
    }
    if (!replaceNonFiniteValues)
    {
      throw std::runtime_error(what + " has " + std::to_string(repair.NonFiniteValues) +
        " NaN or infinite values: repair the file, or turn ReplaceNonFiniteValues on to set "
        "them to 0.");
    }
  }
  // Radiance cannot be negative; lossy EXR compression (DWAA/DWAB, B44) undershoots to about
  // -1e-3 near black, as in Debian's Blender studio lights.
  const cv::Mat negative = samples < 0.0f;
  repair.NegativeValuesClamped = cv::countNonZero(negative);
  if (repair.NegativeValuesClamped > 0)
  {
    samples.setTo(0.0f, negative);
  }
  return repair;
}
}
}
