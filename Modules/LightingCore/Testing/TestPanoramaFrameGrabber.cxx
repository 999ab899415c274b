// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/PanoramaFrameGrabber.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <opencv2/videoio/registry.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

namespace
{
using hv::lighting::PanoramaFrame;
using hv::lighting::PanoramaFrameGrabber;
using hv::lighting::PanoramaFrameGrabberOptions;
using hv::lighting::PanoramaFrameGrabberStatus;
using hv::lighting::PanoramaSourceKind;
using hv::lighting::PixelEncoding;
namespace fs = std::filesystem;

// The synthetic clip: 256x128 frames. The top half is one flat colour whose green encodes the
// frame number (R = 200 and B = 40 differ, so a red/blue swap shows); the bottom half holds
// the frame number's five bits as black/white 32-pixel-wide bars, readable through any lossy
// codec.
constexpr int ClipWidth = 256;
constexpr int ClipHeight = 128;
constexpr int ClipFrames = 30;
constexpr int TopRed = 200;
constexpr int TopBlue = 40;
int topGreen(int frame)
{
  return 10 + 8 * frame;
}

cv::Mat clipFrameRgb(int frame)
{
  cv::Mat rgb(ClipHeight, ClipWidth, CV_8UC3, cv::Scalar(0, 0, 0));
  rgb(cv::Rect(0, 0, ClipWidth, ClipHeight / 2))
    .setTo(cv::Scalar(TopRed, topGreen(frame), TopBlue));
  for (int bit = 0; bit < 5; ++bit)
  {
    const int value = (frame >> bit) & 1 ? 235 : 16;
    rgb(cv::Rect(32 + 32 * bit, ClipHeight / 2, 32, ClipHeight / 2))
      .setTo(cv::Scalar(value, value, value));
  }
  return rgb;
}

// Reads back the frame number from the bars of an RGB frame.
int decodeClipFrameNumber(const cv::Mat& rgb)
{
  int frame = 0;
  for (int bit = 0; bit < 5; ++bit)
  {
    const cv::Scalar mean = cv::mean(rgb(cv::Rect(32 + 32 * bit + 8, ClipHeight / 2 + 8, 16, 48)));
    frame |= (mean[1] > 125.0 ? 1 : 0) << bit;
  }
  return frame;
}

// Largest deviation of the top colour's mean (away from the block edges) from its written value.
double topColourError(const cv::Mat& rgb, int frame)
{
  const cv::Scalar mean = cv::mean(rgb(cv::Rect(16, 8, ClipWidth - 32, ClipHeight / 2 - 16)));
  return std::max({ std::abs(mean[0] - TopRed), std::abs(mean[1] - topGreen(frame)),
    std::abs(mean[2] - TopBlue) });
}

bool writeClip(const std::string& path, int fourcc, double fps)
{
  cv::VideoWriter writer(path, cv::CAP_FFMPEG, fourcc, fps, cv::Size(ClipWidth, ClipHeight));
  if (!writer.isOpened())
  {
    return false;
  }
  cv::Mat bgr;
  for (int frame = 0; frame < ClipFrames; ++frame)
  {
    cv::cvtColor(clipFrameRgb(frame), bgr, cv::COLOR_RGB2BGR);
    writer.write(bgr);
  }
  return true;
}

PanoramaFrameGrabberOptions fastReconnect()
{
  PanoramaFrameGrabberOptions options;
  options.ReconnectInitialDelay = 0.05;
  options.ReconnectMaxDelay = 0.4;
  options.OpenTimeout = 2.0;
  options.ReadTimeout = 1.0;
  return options;
}

template <typename Predicate>
bool waitUntil(Predicate predicate, double seconds)
{
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < deadline)
  {
    if (predicate())
    {
      return true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return predicate();
}

double elapsedMs(std::chrono::steady_clock::time_point start)
{
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
    .count();
}

// Reads a video through the grabber, paced at the file's rate, and checks every frame it
// delivers: frame numbers increase, the content is the one written for that number, in RGB.
void checkClipReadBack(const std::string& path, const char* codec)
{
  PanoramaFrameGrabberOptions options;
  options.PaceToFrameRate = true;
  PanoramaFrameGrabber grabber(options);
  ASSERT_NO_THROW(grabber.open(path));
  EXPECT_EQ(grabber.sourceKind(), PanoramaSourceKind::VideoFile);
  PanoramaFrame frame;
  std::int64_t last = -1;
  int delivered = 0;
  double worstColourError = 0.0;
  while (grabber.waitForFrame(frame, last, 2.0))
  {
    ASSERT_GT(frame.Index, last);
    ASSERT_EQ(frame.Image.type(), CV_8UC3);
    ASSERT_EQ(frame.Image.size(), cv::Size(ClipWidth, ClipHeight));
    EXPECT_EQ(frame.Encoding, PixelEncoding::DisplayReferred);
    EXPECT_EQ(decodeClipFrameNumber(frame.Image), frame.Index) << codec;
    worstColourError = std::max(worstColourError, topColourError(frame.Image, int(frame.Index)));
    last = frame.Index;
    ++delivered;
  }
  const PanoramaFrameGrabberStatus status = grabber.status();
  std::cout << "[ figures  ] " << codec << ": " << delivered << " of " << status.FramesReceived
            << " frames delivered at " << status.FrameRate
            << " fps, worst top-colour error = " << worstColourError << " (8-bit levels)\n";
  EXPECT_EQ(status.FramesReceived, ClipFrames);
  EXPECT_TRUE(status.Finished);
  EXPECT_FALSE(status.Connected);
  EXPECT_EQ(status.FramesDelivered + status.FramesDropped, status.FramesReceived);
  // Paced at 60 fps a waiting consumer keeps up; allow a few frames lost to a busy machine.
  EXPECT_GE(delivered, ClipFrames - 5);
  // Flat areas survive H.264 and MJPEG at the writer's default quality within a few levels
  // (measured here: 4 for H.264, 2.1 for MJPEG); a swapped R and B would be off by 160.
  EXPECT_LT(worstColourError, 8.0) << codec;
}

// A child process: the HTTP stream server script.
class StreamServer
{
public:
  ~StreamServer() { this->stop(); }

  // Starts the server and returns the port it listens on (0 on failure).
  int start(const std::string& file, int port, double bytesPerSecond, bool loop)
  {
    const fs::path script = fs::path(__FILE__).parent_path() / "Scripts" / "serve_frame_stream.py";
    if (!fs::exists(script))
    {
      ADD_FAILURE() << "missing " << script;
      return 0;
    }
    int pipeFds[2];
    if (pipe(pipeFds) != 0)
    {
      return 0;
    }
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, pipeFds[1], STDOUT_FILENO);
    posix_spawn_file_actions_addclose(&actions, pipeFds[0]);
    std::vector<std::string> args = { HOLOVOLUME_PYTHON, script.string(), file, "--port",
      std::to_string(port), "--rate", std::to_string(bytesPerSecond) };
    if (loop)
    {
      args.emplace_back("--loop");
    }
    std::vector<char*> argv;
    for (std::string& arg : args)
    {
      argv.push_back(arg.data());
    }
    argv.push_back(nullptr);
    const int spawned =
      posix_spawn(&this->Pid, HOLOVOLUME_PYTHON, &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    close(pipeFds[1]);
    if (spawned != 0)
    {
      close(pipeFds[0]);
      this->Pid = -1;
      return 0;
    }
    // The script prints "PORT <n>" once it accepts connections.
    std::string line;
    pollfd readable = { pipeFds[0], POLLIN, 0 };
    char c = 0;
    while (line.find('\n') == std::string::npos && poll(&readable, 1, 10000) > 0 &&
      read(pipeFds[0], &c, 1) == 1)
    {
      line += c;
    }
    close(pipeFds[0]);
    int listening = 0;
    if (std::sscanf(line.c_str(), "PORT %d", &listening) != 1)
    {
      ADD_FAILURE() << "stream server did not start: '" << line << "'";
      this->stop();
    }
    return listening;
  }

  void stop()
  {
    if (this->Pid > 0)
    {
      kill(this->Pid, SIGTERM);
      int status = 0;
      waitpid(this->Pid, &status, 0);
      this->Pid = -1;
    }
  }

private:
  pid_t Pid = -1;
};

// A localhost port nobody listens on (bound, then released).
int unusedPort()
{
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  socklen_t length = sizeof(address);
  bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address));
  getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length);
  close(fd);
  return ntohs(address.sin_port);
}

void writeExr(const std::string& path, const cv::Mat& rgb)
{
  auto output = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(output);
  OIIO::ImageSpec spec(rgb.cols, rgb.rows, rgb.channels(), OIIO::TypeDesc::FLOAT);
  ASSERT_TRUE(output->open(path, spec));
  ASSERT_TRUE(output->write_image(OIIO::TypeDesc::FLOAT, rgb.ptr<float>()));
  output->close();
}

std::string expectThrow(const std::string& source, const PanoramaFrameGrabberOptions& options = {})
{
  PanoramaFrameGrabber grabber(options);
  try
  {
    grabber.open(source);
  }
  catch (const std::exception& e)
  {
    EXPECT_FALSE(grabber.isOpen());
    return e.what();
  }
  ADD_FAILURE() << "open('" << source << "') did not throw";
  return {};
}
}

TEST(PanoramaFrameGrabber, BackendsArePresent)
{
  std::cout << "[ figures  ] videoio backends:";
  for (const cv::VideoCaptureAPIs backend : cv::videoio_registry::getBackends())
  {
    std::cout << " " << cv::videoio_registry::getBackendName(backend);
  }
  std::cout << "\n";
  // Video files and network streams go through FFmpeg; without it nothing below can work.
  EXPECT_TRUE(cv::videoio_registry::hasBackend(cv::CAP_FFMPEG));
}

TEST(PanoramaFrameGrabber, ClassifiesSources)
{
  EXPECT_EQ(PanoramaFrameGrabber::classifySource("rtsp://cam.local:554/live"),
    PanoramaSourceKind::NetworkStream);
  EXPECT_EQ(
    PanoramaFrameGrabber::classifySource("udp://@:1234"), PanoramaSourceKind::NetworkStream);
  EXPECT_EQ(PanoramaFrameGrabber::classifySource("/dev/video2"), PanoramaSourceKind::Device);
  EXPECT_EQ(PanoramaFrameGrabber::classifySource("0"), PanoramaSourceKind::Device);
  EXPECT_EQ(
    PanoramaFrameGrabber::classifySource("pano_%04d.png"), PanoramaSourceKind::ImageSequence);
  EXPECT_EQ(
    PanoramaFrameGrabber::classifySource("100%%_%d.exr"), PanoramaSourceKind::ImageSequence);
  EXPECT_EQ(PanoramaFrameGrabber::classifySource("pano.PNG"), PanoramaSourceKind::ImageFile);
  EXPECT_EQ(PanoramaFrameGrabber::classifySource("sky.exr"), PanoramaSourceKind::ImageFile);
  EXPECT_EQ(PanoramaFrameGrabber::classifySource("clip.mp4"), PanoramaSourceKind::VideoFile);
  EXPECT_EQ(PanoramaFrameGrabber::classifySource("100%%.mkv"), PanoramaSourceKind::VideoFile);
}

TEST(PanoramaFrameGrabber, ReadsH264Mp4InOrderInRgb)
{
  const std::string path = "PanoramaFrameGrabber_clip_h264.mp4";
  if (!writeClip(path, cv::VideoWriter::fourcc('a', 'v', 'c', '1'), 60.0))
  {
    GTEST_SKIP() << "OpenCV's FFmpeg writer has no H.264 encoder here";
  }
  checkClipReadBack(path, "H.264/MP4");
}

TEST(PanoramaFrameGrabber, ReadsMjpegAviInOrderInRgb)
{
  const std::string path = "PanoramaFrameGrabber_clip_mjpg.avi";
  ASSERT_TRUE(writeClip(path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 60.0));
  checkClipReadBack(path, "MJPEG/AVI");
}

TEST(PanoramaFrameGrabber, UnpacedFileEndsAndLoops)
{
  const std::string path = "PanoramaFrameGrabber_clip_end.avi";
  ASSERT_TRUE(writeClip(path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 30.0));
  {
    PanoramaFrameGrabber grabber;
    grabber.open(path);
    ASSERT_TRUE(waitUntil([&] { return grabber.status().Finished; }, 10.0));
    PanoramaFrameGrabberStatus status = grabber.status();
    EXPECT_EQ(status.FramesReceived, ClipFrames);
    // Nobody took frames while the decoder ran: all but the last one were overwritten.
    EXPECT_EQ(status.FramesDropped, ClipFrames - 1);
    PanoramaFrame frame = grabber.latest();
    EXPECT_EQ(frame.Index, ClipFrames - 1);
    EXPECT_EQ(decodeClipFrameNumber(frame.Image), ClipFrames - 1);
    EXPECT_FALSE(grabber.waitForFrame(frame, frame.Index, 1.0)); // finished: returns at once
    EXPECT_EQ(grabber.status().FramesDelivered, 1);
  }
  {
    PanoramaFrameGrabberOptions options;
    options.Loop = true;
    PanoramaFrameGrabber grabber(options);
    grabber.open(path);
    ASSERT_TRUE(waitUntil([&] { return grabber.status().FramesReceived > 3 * ClipFrames; }, 20.0));
    const PanoramaFrame frame = grabber.latest();
    EXPECT_GE(frame.Index, 3 * ClipFrames);
    EXPECT_EQ(decodeClipFrameNumber(frame.Image), frame.Index % ClipFrames);
    EXPECT_FALSE(grabber.status().Finished);
  }
}

TEST(PanoramaFrameGrabber, SlowConsumerSeesNewestFramesAndCountsDrops)
{
  const std::string path = "PanoramaFrameGrabber_clip_slow.avi";
  ASSERT_TRUE(writeClip(path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 30.0));
  PanoramaFrameGrabberOptions options;
  options.Loop = true; // unpaced: the decoder runs as fast as it can
  PanoramaFrameGrabber grabber(options);
  grabber.open(path);
  // The capture thread's start and the file's opening are not what this test measures; on a
  // loaded machine they took longer than the consumer's first takes (CI once saw 3 of 10).
  ASSERT_TRUE(waitUntil([&] { return grabber.status().FramesReceived > 0; }, 20.0));
  std::int64_t last = -1;
  std::vector<std::int64_t> taken;
  for (int i = 0; i < 10; ++i)
  {
    std::this_thread::sleep_for(std::chrono::milliseconds(50)); // a slow consumer
    PanoramaFrame frame;
    // The decoder produces a frame in about a millisecond; the wait only covers a stalled
    // machine and never returns an old frame.
    if (waitUntil([&] { return grabber.tryGetNewFrame(frame, last); }, 5.0))
    {
      EXPECT_GT(frame.Index, last);
      EXPECT_EQ(decodeClipFrameNumber(frame.Image), frame.Index % ClipFrames);
      last = frame.Index;
      taken.push_back(frame.Index);
    }
  }
  grabber.close();
  const PanoramaFrameGrabberStatus status = grabber.status();
  std::cout << "[ figures  ] slow consumer took " << taken.size() << " frames, last index " << last
            << "; received " << status.FramesReceived << ", dropped " << status.FramesDropped
            << "\n";
  EXPECT_EQ(taken.size(), 10u);
  // Between two takes 50 ms apart the decoder produced several frames: some were skipped.
  EXPECT_GT(last, static_cast<std::int64_t>(taken.size()));
  EXPECT_GT(status.FramesDropped, 0);
  EXPECT_EQ(status.FramesDelivered, static_cast<std::int64_t>(taken.size()));
  // Every received frame was either delivered, dropped, or is the one still waiting.
  const std::int64_t unaccounted =
    status.FramesReceived - status.FramesDelivered - status.FramesDropped;
  EXPECT_GE(unaccounted, 0);
  EXPECT_LE(unaccounted, 1);
}

TEST(PanoramaFrameGrabber, DeliverEveryFrameHandsOverEveryFrameInOrder)
{
  // The same slow consumer as above, on a paced 30 fps clip and on an unpaced one: with
  // DeliverEveryFrame it takes every frame in order, whatever the decoder's or the file's rate.
  const std::string path = "PanoramaFrameGrabber_clip_every.avi";
  ASSERT_TRUE(writeClip(path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 30.0));
  for (const bool paced : { false, true })
  {
    PanoramaFrameGrabberOptions options;
    options.DeliverEveryFrame = true;
    options.PaceToFrameRate = paced;
    PanoramaFrameGrabber grabber(options);
    grabber.open(path);
    std::vector<std::int64_t> taken{ grabber.latest().Index };
    PanoramaFrame frame;
    while (grabber.waitForFrame(frame, taken.back(), 10.0))
    {
      EXPECT_EQ(decodeClipFrameNumber(frame.Image), frame.Index);
      taken.push_back(frame.Index);
      // Slower than the file's 33 ms a frame, and far slower than the decoder.
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    const PanoramaFrameGrabberStatus status = grabber.status();
    std::cout << "[ figures  ] " << (paced ? "paced" : "unpaced") << ", every frame: took "
              << taken.size() << " of " << ClipFrames << " frames, received "
              << status.FramesReceived << ", dropped " << status.FramesDropped << "\n";
    ASSERT_EQ(taken.size(), static_cast<std::size_t>(ClipFrames));
    for (std::size_t i = 0; i < taken.size(); ++i)
    {
      EXPECT_EQ(taken[i], static_cast<std::int64_t>(i));
    }
    EXPECT_TRUE(status.Finished);
    EXPECT_EQ(status.FramesDropped, 0);
    EXPECT_EQ(status.FramesDelivered, ClipFrames);
  }
  // A consumer that takes no frame after the first holds the decoder at frame 1, the first
  // not taken, and close() still returns at once.
  PanoramaFrameGrabberOptions options;
  options.DeliverEveryFrame = true;
  PanoramaFrameGrabber grabber(options);
  grabber.open(path);
  grabber.latest();
  ASSERT_TRUE(waitUntil([&] { return grabber.status().FramesReceived >= 2; }, 20.0));
  std::this_thread::sleep_for(std::chrono::milliseconds(200)); // time to run ahead, if it could
  EXPECT_EQ(grabber.status().FramesReceived, 2);
  EXPECT_EQ(grabber.status().FramesDropped, 0);
  const auto start = std::chrono::steady_clock::now();
  grabber.close();
  EXPECT_LT(elapsedMs(start), 1000.0);
}

TEST(PanoramaFrameGrabber, LatestNeverWaitsForTheSource)
{
  // A 5 fps live-like source: a call that waited for the next frame would take up to 200 ms.
  const std::string path = "PanoramaFrameGrabber_clip_5fps.avi";
  ASSERT_TRUE(writeClip(path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 5.0));
  PanoramaFrameGrabberOptions options;
  options.PaceToFrameRate = true;
  options.Loop = true;
  PanoramaFrameGrabber grabber(options);
  grabber.open(path);
  std::vector<double> microseconds;
  std::int64_t firstIndex = grabber.latest().Index;
  std::int64_t lastIndex = firstIndex;
  const auto start = std::chrono::steady_clock::now();
  while (elapsedMs(start) < 600.0)
  {
    const auto before = std::chrono::steady_clock::now();
    const PanoramaFrame frame = grabber.latest();
    microseconds.push_back(1000.0 * elapsedMs(before));
    EXPECT_GE(frame.Index, lastIndex);
    lastIndex = frame.Index;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  std::sort(microseconds.begin(), microseconds.end());
  const double median = microseconds[microseconds.size() / 2];
  const double worst = microseconds.back();
  std::cout << "[ figures  ] latest(): " << microseconds.size() << " calls, median " << median
            << " us, worst " << worst << " us, frames " << firstIndex << ".." << lastIndex << "\n";
  EXPECT_GT(lastIndex, firstIndex); // frames did arrive meanwhile
  EXPECT_LT(median, 50.0);
  // Generous for a shared machine, yet far below the 200 ms a blocking call would take.
  EXPECT_LT(worst, 20000.0);
}

TEST(PanoramaFrameGrabber, NumberedPngSequence)
{
  const fs::path directory = "PanoramaFrameGrabber_sequence";
  fs::remove_all(directory);
  fs::create_directories(directory);
  // Numbers 1..5: the sequence starts at the lowest existing number.
  for (int number = 1; number <= 5; ++number)
  {
    cv::Mat bgr(32, 64, CV_8UC3, cv::Scalar(10, 20 * number, 250));
    char name[64];
    std::snprintf(name, sizeof(name), "pano_%04d.png", number);
    ASSERT_TRUE(cv::imwrite((directory / name).string(), bgr));
  }
  const std::string pattern = (directory / "pano_%04d.png").string();
  for (const bool loop : { false, true })
  {
    PanoramaFrameGrabberOptions options;
    options.PaceToFrameRate = true;
    options.DefaultFrameRate = 50.0;
    options.Loop = loop;
    PanoramaFrameGrabber grabber(options);
    grabber.open(pattern);
    EXPECT_EQ(grabber.sourceKind(), PanoramaSourceKind::ImageSequence);
    PanoramaFrame frame;
    std::int64_t last = -1;
    int delivered = 0;
    while (last < 12 && grabber.waitForFrame(frame, last, 2.0))
    {
      const int number = static_cast<int>(frame.Index % 5) + 1;
      const cv::Vec3b pixel = frame.Image.at<cv::Vec3b>(5, 5);
      EXPECT_EQ(pixel, cv::Vec3b(250, static_cast<uchar>(20 * number), 10)) << frame.Index;
      EXPECT_EQ(frame.Encoding, PixelEncoding::DisplayReferred);
      last = frame.Index;
      ++delivered;
    }
    if (loop)
    {
      EXPECT_GE(last, 12);
      EXPECT_FALSE(grabber.status().Finished);
    }
    else
    {
      EXPECT_EQ(last, 4);
      EXPECT_EQ(grabber.status().FramesReceived, 5);
      EXPECT_TRUE(grabber.status().Finished);
    }
    EXPECT_GE(delivered, loop ? 10 : 4);
  }
  EXPECT_NE(expectThrow((directory / "none_%02d.png").string()).find("No image matches"),
    std::string::npos);
  EXPECT_NE(expectThrow((directory / "pano_%s.png").string()).find("%04d"), std::string::npos);
}

TEST(PanoramaFrameGrabber, SixteenBitGreyAndAlphaPngs)
{
  cv::Mat bgr16(16, 32, CV_16UC3, cv::Scalar(1000, 30000, 65000));
  ASSERT_TRUE(cv::imwrite("PanoramaFrameGrabber_16bit.png", bgr16));
  PanoramaFrame frame = PanoramaFrameGrabber::readImage("PanoramaFrameGrabber_16bit.png");
  ASSERT_EQ(frame.Image.type(), CV_16UC3);
  EXPECT_EQ(frame.Encoding, PixelEncoding::DisplayReferred);
  EXPECT_EQ(frame.Image.at<cv::Vec3w>(3, 7), cv::Vec3w(65000, 30000, 1000));

  cv::Mat grey(16, 32, CV_8UC1);
  for (int x = 0; x < grey.cols; ++x)
  {
    grey.col(x).setTo(8 * x);
  }
  ASSERT_TRUE(cv::imwrite("PanoramaFrameGrabber_grey.png", grey));
  PanoramaFrameGrabber grabber;
  grabber.open("PanoramaFrameGrabber_grey.png");
  EXPECT_EQ(grabber.sourceKind(), PanoramaSourceKind::ImageFile);
  frame = grabber.latest();
  ASSERT_EQ(frame.Image.type(), CV_8UC3);
  for (int x = 0; x < grey.cols; ++x)
  {
    EXPECT_EQ(frame.Image.at<cv::Vec3b>(9, x), cv::Vec3b(8 * x, 8 * x, 8 * x));
  }
  // A still image is one frame.
  EXPECT_TRUE(waitUntil([&] { return grabber.status().Finished; }, 5.0));
  EXPECT_EQ(grabber.status().FramesReceived, 1);

  cv::Mat bgra(8, 8, CV_8UC4, cv::Scalar(30, 60, 90, 7));
  ASSERT_TRUE(cv::imwrite("PanoramaFrameGrabber_alpha.png", bgra));
  frame = PanoramaFrameGrabber::readImage("PanoramaFrameGrabber_alpha.png");
  ASSERT_EQ(frame.Image.type(), CV_8UC3);
  EXPECT_EQ(frame.Image.at<cv::Vec3b>(4, 4), cv::Vec3b(90, 60, 30));
}

TEST(PanoramaFrameGrabber, UnsupportedPixelTypesAreErrors)
{
  cv::Mat rgb;
  const cv::Mat signedImage(4, 4, CV_16SC3, cv::Scalar(1, 2, 3));
  try
  {
    PanoramaFrameGrabber::convertToRgb(signedImage, rgb, "test image");
    ADD_FAILURE() << "16-bit signed accepted";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("16-bit signed"), std::string::npos) << e.what();
  }
  const cv::Mat twoChannels(4, 4, CV_8UC2, cv::Scalar(1, 2));
  EXPECT_THROW(
    PanoramaFrameGrabber::convertToRgb(twoChannels, rgb, "test image"), std::runtime_error);
  // A 16-bit signed TIFF decodes to CV_16S, which the grabber refuses naming file and type.
  const cv::Mat signedGrey(4, 4, CV_16SC1, cv::Scalar(-7));
  ASSERT_TRUE(cv::imwrite("PanoramaFrameGrabber_signed.tiff", signedGrey));
  const std::string message = expectThrow("PanoramaFrameGrabber_signed.tiff");
  EXPECT_NE(message.find("PanoramaFrameGrabber_signed.tiff"), std::string::npos) << message;
  EXPECT_NE(message.find("16-bit signed"), std::string::npos) << message;
  // Garbage with an image extension.
  std::ofstream("PanoramaFrameGrabber_garbage.png") << "not a png";
  EXPECT_NE(
    expectThrow("PanoramaFrameGrabber_garbage.png").find("PanoramaFrameGrabber_garbage.png"),
    std::string::npos);
}

TEST(PanoramaFrameGrabber, ExrNonFiniteRejectedOrReplacedNegativesClamped)
{
  cv::Mat radiance(8, 16, CV_32FC3, cv::Scalar(0.5f, 2.0f, 40.0f));
  radiance.at<cv::Vec3f>(2, 3)[1] = std::numeric_limits<float>::quiet_NaN();
  radiance.at<cv::Vec3f>(5, 9)[0] = std::numeric_limits<float>::infinity();
  radiance.at<cv::Vec3f>(7, 15)[2] = -1.0e-3f;
  writeExr("PanoramaFrameGrabber_nan.exr", radiance);

  const std::string message = expectThrow("PanoramaFrameGrabber_nan.exr");
  EXPECT_NE(message.find("PanoramaFrameGrabber_nan.exr"), std::string::npos) << message;
  EXPECT_NE(message.find("2 NaN or infinite"), std::string::npos) << message;
  EXPECT_NE(message.find("ReplaceNonFiniteValues"), std::string::npos) << message;

  PanoramaFrameGrabberOptions options;
  options.ReplaceNonFiniteValues = true;
  PanoramaFrameGrabber grabber(options);
  grabber.open("PanoramaFrameGrabber_nan.exr");
  const PanoramaFrame frame = grabber.latest();
  ASSERT_EQ(frame.Image.type(), CV_32FC3);
  EXPECT_EQ(frame.Encoding, PixelEncoding::SceneLinear);
  EXPECT_EQ(frame.Image.at<cv::Vec3f>(2, 3), cv::Vec3f(0.5f, 0.0f, 40.0f));
  EXPECT_EQ(frame.Image.at<cv::Vec3f>(5, 9), cv::Vec3f(0.0f, 2.0f, 40.0f));
  EXPECT_EQ(frame.Image.at<cv::Vec3f>(7, 15), cv::Vec3f(0.5f, 2.0f, 0.0f));
  EXPECT_EQ(frame.Image.at<cv::Vec3f>(0, 0), cv::Vec3f(0.5f, 2.0f, 40.0f)); // RGB, exact

  cv::Mat copy = radiance.clone();
  const hv::lighting::SceneLinearRepair repair =
    PanoramaFrameGrabber::sanitizeSceneLinear(copy, true, "test");
  EXPECT_EQ(repair.NonFiniteValues, 2);
  EXPECT_EQ(repair.NegativeValuesClamped, 1);

  // A one-channel EXR is grey: replicated into R, G, B.
  cv::Mat grey(4, 8, CV_32FC1, cv::Scalar(3.25f));
  writeExr("PanoramaFrameGrabber_grey.exr", grey);
  const PanoramaFrame greyFrame = PanoramaFrameGrabber::readImage("PanoramaFrameGrabber_grey.exr");
  ASSERT_EQ(greyFrame.Image.type(), CV_32FC3);
  EXPECT_EQ(greyFrame.Image.at<cv::Vec3f>(1, 1), cv::Vec3f(3.25f, 3.25f, 3.25f));
}

TEST(PanoramaFrameGrabber, FloatTiffIsSceneLinear)
{
  // OpenCV decodes float TIFF (BGR); it is scene-linear like EXR and sanitised the same way.
  // OpenCV writes 3-channel float TIFF as SGI LogLuv, good to about 1 %.
  cv::Mat bgr(4, 8, CV_32FC3, cv::Scalar(7.5f, 0.5f, -0.25f));
  ASSERT_TRUE(cv::imwrite("PanoramaFrameGrabber_float.tiff", bgr));
  const PanoramaFrame frame = PanoramaFrameGrabber::readImage("PanoramaFrameGrabber_float.tiff");
  ASSERT_EQ(frame.Image.type(), CV_32FC3);
  EXPECT_EQ(frame.Encoding, PixelEncoding::SceneLinear);
  const cv::Vec3f value = frame.Image.at<cv::Vec3f>(2, 2);
  EXPECT_EQ(value[0], 0.0f); // negative clamped
  EXPECT_NEAR(value[1], 0.5f, 0.02f * 0.5f);
  EXPECT_NEAR(value[2], 7.5f, 0.02f * 7.5f); // RGB order
}

TEST(PanoramaFrameGrabber, RadianceHdrFile)
{
  cv::Mat radiance(8, 16, CV_32FC3, cv::Scalar(0.25f, 1.0f, 300.0f));
  {
    auto output = OIIO::ImageOutput::create("PanoramaFrameGrabber_sky.hdr");
    ASSERT_TRUE(output);
    OIIO::ImageSpec spec(radiance.cols, radiance.rows, 3, OIIO::TypeDesc::FLOAT);
    ASSERT_TRUE(output->open("PanoramaFrameGrabber_sky.hdr", spec));
    ASSERT_TRUE(output->write_image(OIIO::TypeDesc::FLOAT, radiance.ptr<float>()));
  }
  const PanoramaFrame frame = PanoramaFrameGrabber::readImage("PanoramaFrameGrabber_sky.hdr");
  ASSERT_EQ(frame.Image.type(), CV_32FC3);
  EXPECT_EQ(frame.Encoding, PixelEncoding::SceneLinear);
  const cv::Vec3f value = frame.Image.at<cv::Vec3f>(4, 4);
  // RGBE shares one exponent: the smaller channels keep 8 bits relative to the largest, so
  // 0.25 next to 300 is only good to 300/256 ~ 1.2.
  EXPECT_NEAR(value[2], 300.0f, 300.0f / 256.0f);
  EXPECT_NEAR(value[1], 1.0f, 300.0f / 256.0f);
  EXPECT_NEAR(value[0], 0.25f, 300.0f / 256.0f);
  EXPECT_GT(value[2], 100.0f * value[0]); // R and B not swapped
}

TEST(PanoramaFrameGrabber, DebianBlenderExrNegativesClamped)
{
  const std::string path = "/usr/share/blender/datafiles/studiolights/world/forest.exr";
  if (!fs::exists(path))
  {
    GTEST_SKIP() << path << " is not installed (Debian package blender-data)";
  }
  const PanoramaFrame frame = PanoramaFrameGrabber::readImage(path);
  ASSERT_EQ(frame.Image.type(), CV_32FC3);
  double minimum = 0.0, maximum = 0.0;
  cv::minMaxLoc(frame.Image.reshape(1), &minimum, &maximum);
  EXPECT_GE(minimum, 0.0);
  EXPECT_TRUE(std::isfinite(maximum));
  EXPECT_GT(maximum, 1.0); // HDR: brighter than what an 8-bit sensor clips at
}

TEST(PanoramaFrameGrabber, UnopenableSourcesThrowUsefulMessages)
{
  std::string message = expectThrow("PanoramaFrameGrabber_no_such_clip.mp4");
  EXPECT_NE(message.find("does not exist"), std::string::npos) << message;
  EXPECT_NE(message.find("PanoramaFrameGrabber_no_such_clip.mp4"), std::string::npos);

  std::ofstream("PanoramaFrameGrabber_garbage.mp4") << std::string(4096, 'x');
  message = expectThrow("PanoramaFrameGrabber_garbage.mp4");
  EXPECT_NE(message.find("PanoramaFrameGrabber_garbage.mp4"), std::string::npos) << message;
  EXPECT_NE(message.find("codec"), std::string::npos) << message;

  message = expectThrow("/dev/video99");
  EXPECT_NE(message.find("/dev/video99"), std::string::npos) << message;
  EXPECT_NE(message.find("camera"), std::string::npos) << message;

  const std::string url = "http://127.0.0.1:" + std::to_string(unusedPort()) + "/clip.ts";
  const auto start = std::chrono::steady_clock::now();
  message = expectThrow(url, fastReconnect());
  EXPECT_LT(elapsedMs(start), 3000.0); // within OpenTimeout (2 s) and a margin
  EXPECT_NE(message.find(url), std::string::npos) << message;
  EXPECT_NE(message.find("reachable"), std::string::npos) << message;

  EXPECT_NE(expectThrow("123456").find("./123456"), std::string::npos);
  EXPECT_THROW(PanoramaFrameGrabber().open(""), std::invalid_argument);
}

TEST(PanoramaFrameGrabber, ClosedGrabberIsSafe)
{
  PanoramaFrameGrabber grabber;
  EXPECT_FALSE(grabber.isOpen());
  EXPECT_EQ(grabber.latest().Index, -1);
  EXPECT_TRUE(grabber.latest().Image.empty());
  PanoramaFrame frame;
  EXPECT_FALSE(grabber.tryGetNewFrame(frame, -1));
  const auto start = std::chrono::steady_clock::now();
  EXPECT_FALSE(grabber.waitForFrame(frame, -1, 5.0));
  EXPECT_LT(elapsedMs(start), 100.0); // closed: no waiting
  grabber.close();
  grabber.close();
  EXPECT_FALSE(grabber.status().Open);

  cv::Mat bgr(8, 8, CV_8UC3, cv::Scalar(1, 2, 3));
  ASSERT_TRUE(cv::imwrite("PanoramaFrameGrabber_closed.png", bgr));
  grabber.open("PanoramaFrameGrabber_closed.png");
  EXPECT_TRUE(grabber.isOpen());
  grabber.close();
  EXPECT_FALSE(grabber.isOpen());
  EXPECT_EQ(grabber.latest().Index, -1);
  EXPECT_EQ(grabber.status().FramesReceived, 1); // counters stay readable after close()
}

// A live HTTP stream (H.264 in MPEG-TS, sent at its recording rate, endless) whose server
// goes away and comes back on the same port.
TEST(PanoramaFrameGrabber, NetworkStreamReconnectsAfterDrop)
{
  const std::string path = "PanoramaFrameGrabber_clip.ts";
  if (!writeClip(path, cv::VideoWriter::fourcc('a', 'v', 'c', '1'), 30.0))
  {
    ASSERT_TRUE(writeClip(path, cv::VideoWriter::fourcc('m', 'p', 'e', 'g'), 30.0));
  }
  const double bytesPerSecond = static_cast<double>(fs::file_size(path)) / (ClipFrames / 30.0);
  StreamServer server;
  const int port = server.start(path, 0, bytesPerSecond, true);
  ASSERT_GT(port, 0);
  const std::string url = "http://127.0.0.1:" + std::to_string(port) + "/" + path;

  PanoramaFrameGrabber grabber(fastReconnect());
  ASSERT_NO_THROW(grabber.open(url));
  EXPECT_EQ(grabber.sourceKind(), PanoramaSourceKind::NetworkStream);
  ASSERT_TRUE(waitUntil([&] { return grabber.status().FramesReceived >= 15; }, 10.0));
  PanoramaFrame frame = grabber.latest();
  EXPECT_EQ(decodeClipFrameNumber(frame.Image), frame.Index % ClipFrames);
  EXPECT_LT(topColourError(frame.Image, int(frame.Index % ClipFrames)), 8.0);
  EXPECT_EQ(grabber.status().Reconnects, 0); // an endless stream: no reconnect so far

  server.stop();
  const auto dropped = std::chrono::steady_clock::now();
  ASSERT_TRUE(waitUntil(
    [&]
    {
      const PanoramaFrameGrabberStatus s = grabber.status();
      return !s.Connected && s.ReconnectAttempts >= 2;
    },
    10.0));
  const double noticedMs = elapsedMs(dropped);
  PanoramaFrameGrabberStatus status = grabber.status();
  EXPECT_FALSE(status.LastError.empty());
  EXPECT_FALSE(status.Finished);
  EXPECT_EQ(status.Reconnects, 0); // nothing to reconnect to
  // Meanwhile the pipeline still gets the last frame at once.
  const auto before = std::chrono::steady_clock::now();
  const std::int64_t lastBeforeDrop = grabber.latest().Index;
  EXPECT_LT(elapsedMs(before), 500.0); // a copy, never a wait for the reconnecting stream (seconds)

  ASSERT_EQ(server.start(path, port, bytesPerSecond, true), port);
  const auto restarted = std::chrono::steady_clock::now();
  ASSERT_TRUE(waitUntil(
    [&]
    {
      const PanoramaFrameGrabberStatus s = grabber.status();
      return s.Connected && s.Reconnects >= 1 && s.FramesReceived >= status.FramesReceived + 15;
    },
    15.0));
  const double recoveredMs = elapsedMs(restarted);
  frame = grabber.latest();
  EXPECT_GT(frame.Index, lastBeforeDrop);
  status = grabber.status();
  std::cout << "[ figures  ] stream drop noticed after " << noticedMs << " ms, frames again "
            << recoveredMs << " ms after the restart; reconnect attempts "
            << status.ReconnectAttempts << ", reconnects " << status.Reconnects << ", received "
            << status.FramesReceived << "\n";
  EXPECT_GE(status.Reconnects, 1);
  grabber.close();
}

// Reconnecting gives up after MaxReconnectAttempts consecutive failures.
TEST(PanoramaFrameGrabber, NetworkStreamGivesUpAfterMaxAttempts)
{
  const std::string path = "PanoramaFrameGrabber_clip_giveup.ts";
  if (!writeClip(path, cv::VideoWriter::fourcc('a', 'v', 'c', '1'), 30.0))
  {
    ASSERT_TRUE(writeClip(path, cv::VideoWriter::fourcc('m', 'p', 'e', 'g'), 30.0));
  }
  StreamServer server;
  const int port = server.start(path, 0, 20000.0, true);
  ASSERT_GT(port, 0);
  PanoramaFrameGrabberOptions options = fastReconnect();
  options.MaxReconnectAttempts = 2;
  PanoramaFrameGrabber grabber(options);
  grabber.open("http://127.0.0.1:" + std::to_string(port) + "/" + path);
  server.stop();
  ASSERT_TRUE(waitUntil([&] { return grabber.status().Finished; }, 10.0));
  const PanoramaFrameGrabberStatus status = grabber.status();
  EXPECT_EQ(status.ReconnectAttempts, 2);
  EXPECT_EQ(status.Reconnects, 0);
  EXPECT_FALSE(status.Connected);
  EXPECT_NE(status.LastError.find("Gave up after 2"), std::string::npos) << status.LastError;
  PanoramaFrame frame = grabber.latest();
  const auto start = std::chrono::steady_clock::now();
  EXPECT_FALSE(grabber.waitForFrame(frame, frame.Index, 5.0)); // finished: no waiting
  EXPECT_LT(elapsedMs(start), 100.0);
}

// A live URL that simply ends (a finished HTTP download) is a dropped stream: reopened.
TEST(PanoramaFrameGrabber, NetworkStreamThatEndsIsReopened)
{
  const std::string path = "PanoramaFrameGrabber_clip_end.ts";
  if (!writeClip(path, cv::VideoWriter::fourcc('a', 'v', 'c', '1'), 30.0))
  {
    ASSERT_TRUE(writeClip(path, cv::VideoWriter::fourcc('m', 'p', 'e', 'g'), 30.0));
  }
  StreamServer server;
  const int port = server.start(path, 0, 0.0, false);
  ASSERT_GT(port, 0);
  PanoramaFrameGrabber grabber(fastReconnect());
  grabber.open("http://127.0.0.1:" + std::to_string(port) + "/" + path);
  ASSERT_TRUE(waitUntil([&] { return grabber.status().Reconnects >= 2; }, 10.0));
  EXPECT_GE(grabber.status().FramesReceived, 2 * ClipFrames);
  EXPECT_FALSE(grabber.status().Finished);

  PanoramaFrameGrabberOptions noReconnect = fastReconnect();
  noReconnect.Reconnect = false;
  PanoramaFrameGrabber once(noReconnect);
  once.open("http://127.0.0.1:" + std::to_string(port) + "/" + path);
  ASSERT_TRUE(waitUntil([&] { return once.status().Finished; }, 10.0));
  EXPECT_EQ(once.status().FramesReceived, ClipFrames);
  EXPECT_EQ(once.status().ReconnectAttempts, 0);
}
