// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_lighting_PanoramaFrameGrabber_h
#define hv_lighting_PanoramaFrameGrabber_h

#include "hv/lighting/Panorama.h"

#include <opencv2/core.hpp>

#include <cstdint>
#include <memory>
#include <string>

namespace hv
{
namespace lighting
{
// What a source string names (see PanoramaFrameGrabber::classifySource).
enum class PanoramaSourceKind
{
  VideoFile,     // any container/codec OpenCV's FFmpeg backend decodes (MP4/H.264, AVI, MKV, TS...)
  Device,        // a camera: "/dev/videoN" (V4L2) or a bare index such as "0"
  NetworkStream, // "scheme://..." (rtsp, rtsps, rtmp, udp, rtp, tcp, srt, http, https) via FFmpeg
  ImageFile,     // one still image (PNG, JPEG, TIFF, ... via OpenCV; EXR, HDR, PFM via OpenImageIO)
  ImageSequence  // numbered images named by a printf pattern, e.g. "frames/pano_%04d.png"
};

const char* toString(PanoramaSourceKind kind);
const char* toString(PixelEncoding encoding);

struct PanoramaFrameGrabberOptions
{
  // Files (videos, sequences): start again at the end instead of stopping. A still image is
  // one frame and is never repeated.
  bool Loop = false;
  // Files: deliver frames at the file's frame rate (a video's own rate, DefaultFrameRate for
  // image sequences and videos without one). Off: decode as fast as possible; since only the
  // newest frame is kept, a consumer slower than the decoder then skips frames.
  bool PaceToFrameRate = false;
  double DefaultFrameRate = 30.0;
  // Files: hand over every frame, in order. The capture thread decodes the next frame only
  // once the last one was taken, so a consumer slower than the file's rate (or than the
  // decoder) drops none; with PaceToFrameRate a frame still comes no earlier than its time.
  // For processing a recording offline, and for results that must not depend on the
  // machine's load. Live sources ignore it: a camera does not wait.
  bool DeliverEveryFrame = false;
  // Live sources (devices and network streams): reopen after the stream drops. A network
  // stream that reaches its end counts as dropped, since a live stream never ends. The wait
  // before each attempt starts at ReconnectInitialDelay and doubles after every failed
  // attempt up to ReconnectMaxDelay (seconds). After MaxReconnectAttempts consecutive
  // failures (0: never) the grabber gives up and reports the source finished.
  bool Reconnect = true;
  double ReconnectInitialDelay = 0.25;
  double ReconnectMaxDelay = 4.0;
  int MaxReconnectAttempts = 0;
  // FFmpeg sources (video files, network streams): the longest an open or a read may take
  // (seconds). A read that stalls longer is a dropped stream; close() can wait this long.
  double OpenTimeout = 5.0;
  double ReadTimeout = 2.0;
  // Scene-linear images (EXR, HDR, float TIFF): NaN and infinite texels make the read fail,
  // naming the file; with this on they are replaced by 0 instead.
  bool ReplaceNonFiniteValues = false;
};

struct PanoramaFrameGrabberStatus
{
  bool Open = false;      // open() succeeded and close() was not called
  bool Connected = false; // the source is delivering (false while reconnecting or at its end)
  bool Finished = false;  // no further frame will come (end of a file, or reconnecting gave up)
  double FrameRate = 0.0; // the source's nominal rate, 0 when unknown
  std::int64_t FramesReceived = 0;    // frames decoded and published since open()
  std::int64_t FramesDelivered = 0;   // distinct frames handed out by latest()/tryGetNewFrame()/...
  std::int64_t FramesDropped = 0;     // frames overwritten by a newer one before anybody took them
  std::int64_t ReconnectAttempts = 0; // reopen attempts, failed or not
  std::int64_t Reconnects = 0;        // successful reopens
  std::string LastError;              // the most recent problem, empty if none
};

// What sanitizeSceneLinear() found and changed.
struct SceneLinearRepair
{
  std::int64_t NonFiniteValues = 0; // NaN or infinite channel values
  std::int64_t NegativeValuesClamped = 0;
};

// Opens a panorama source named by a string and delivers PanoramaFrame images in RGB order.
//
// A capture thread decodes frames and keeps only the newest one ("latest wins"): latest() and
// tryGetNewFrame() return at once with whatever is newest and never wait on the camera, so a
// render loop is never held up by the source; frames that are overwritten before anybody takes
// them are counted as dropped. waitForFrame() blocks, for tools and tests. With
// DeliverEveryFrame a file's thread waits for each frame to be taken instead, and drops none.
//
// Pixel conversions (the documented answer to frames the lighting chain does not take as is):
// - video and camera frames (8-bit BGR from OpenCV) are converted to RGB, CV_8UC3,
//   DisplayReferred;
// - 8- and 16-bit images (PNG, JPEG, TIFF...) give CV_8UC3 / CV_16UC3 DisplayReferred; an EXIF
//   orientation is applied;
// - EXR, Radiance HDR, PFM and float TIFF give CV_32FC3 SceneLinear; negative values (the
//   undershoot of lossy EXR compression) are clamped to 0; NaN/Inf fail the read unless
//   ReplaceNonFiniteValues is on;
// - greyscale is replicated into R, G and B; an alpha channel is dropped; any other pixel type
//   (signed or 64-bit integers, double, more than four unnamed channels) is an error.
// The images handed out share their pixels with the grabber (no copy per take): treat them as
// read-only and clone() before writing into them.
//
// Thread safety: open(), close() and the option setters belong to one owner thread; latest(),
// tryGetNewFrame(), waitForFrame() and status() may be called from any thread.
class PanoramaFrameGrabber
{
public:
  PanoramaFrameGrabber();
  explicit PanoramaFrameGrabber(const PanoramaFrameGrabberOptions& options);
  ~PanoramaFrameGrabber();
  PanoramaFrameGrabber(const PanoramaFrameGrabber&) = delete;
  PanoramaFrameGrabber& operator=(const PanoramaFrameGrabber&) = delete;

  // Options take effect at the next open().
  void setOptions(const PanoramaFrameGrabberOptions& options);
  const PanoramaFrameGrabberOptions& options() const;

  // Opens the source, decodes its first frame (so a source that opens but cannot be decoded
  // fails here) and starts the capture thread. Throws std::invalid_argument for an empty
  // source and std::runtime_error, naming the source and what to check, when it cannot be
  // opened or its first frame cannot be read. Closes a previously opened source first.
  void open(const std::string& source);
  // Stops the capture thread and releases the source; safe to call at any time. May wait up to
  // ReadTimeout for a network read in progress.
  void close();
  bool isOpen() const;
  const std::string& source() const;
  PanoramaSourceKind sourceKind() const;

  // The newest frame (Index -1 and an empty image before open()). Never waits for a frame.
  PanoramaFrame latest();
  // If a frame newer than lastIndex exists, stores it in frame and returns true; otherwise
  // leaves frame alone and returns false. Never waits for a frame.
  bool tryGetNewFrame(PanoramaFrame& frame, std::int64_t lastIndex);
  // Waits up to timeoutSeconds for a frame newer than lastIndex. Returns false on timeout,
  // when the source is finished, or when the grabber is closed.
  bool waitForFrame(PanoramaFrame& frame, std::int64_t lastIndex, double timeoutSeconds);
  PanoramaFrameGrabberStatus status() const;

  // How open() interprets a source string, in this order: "scheme://..." is a network stream;
  // "/dev/video..." or a string of digits is a camera (write "./2024" for a file named 2024); a
  // name containing a printf integer conversion (%d, %4d, %04d; "%%" is a literal percent sign)
  // is an image sequence; a name ending in an image extension is an image file; anything else
  // is a video file.
  static PanoramaSourceKind classifySource(const std::string& source);

  // Reads one image file with the conversions above. Throws std::runtime_error naming the file.
  static PanoramaFrame readImage(const std::string& path, bool replaceNonFiniteValues = false);
  // Converts a decoded OpenCV image (1, 3 or 4 channels in OpenCV's GRAY/BGR/BGRA order;
  // 8U, 16U or 32F) to RGB with 3 channels, writing into rgb (reallocated only when its size
  // or type differs). Throws std::runtime_error for other types; what names the image.
  static void convertToRgb(const cv::Mat& decoded, cv::Mat& rgb, const std::string& what);
  // Clamps negative values of a CV_32F image to 0 and, if replaceNonFiniteValues, sets NaN and
  // infinite values to 0; otherwise throws std::runtime_error naming what if any are present.
  static SceneLinearRepair sanitizeSceneLinear(
    cv::Mat& image, bool replaceNonFiniteValues, const std::string& what);

private:
  struct Internals;
  std::unique_ptr<Internals> Impl;
};
}
}

#endif
