// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// holovolume-remoting-benchmark: the stream on localhost at HoloLens 2 resolution. A C++
// client plays the headset in closed loop: it sends a pose (the head moving on a small arc),
// waits for the frame rendered for that pose, decodes both eyes (as the page would) and sends
// the next pose. Printed per codec, side by side: frames per second, pose-to-decoded latency,
// and the server's render, denoise and encode times and the frame size.
//
//   holovolume-remoting-benchmark [--eye-size 1440x936] [--frames 6] [--no-denoiser]
//                                 [--volume FILE] [--environment FILE]
#include "vtkHoloLensRemotingOutput.h"
#include "vtkHoloVolumeScene.h"
#include "vtkPathTracedVolumeMapper.h"
#include "vtkStereoSpatioTemporalDenoiser.h"

#include "vtkEnvironmentMapReader.h"
#include "vtkNew.h"
#include "vtkVolume.h"

#include "hv/remoting/FrameCodec.h"
#include "hv/remoting/Protocol.h"
#include "hv/remoting/RemotingClient.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

namespace
{
using namespace hv::remoting;

double NowMs()
{
  using namespace std::chrono;
  return duration<double, std::milli>(steady_clock::now().time_since_epoch()).count();
}


// The head 0.7 m in front of the volume, swaying sideways by up to 5 cm.
PoseMessage HeadPose(std::uint64_t poseId, double aspect)
{
  PoseMessage pose;
  pose.poseId = poseId;
  pose.mode = "immersive-ar";
  const double x = 0.05 * std::sin(0.4 * poseId);
  pose.head = IdentityMatrix();
  pose.head[12] = x;
  pose.head[13] = 1.3;
  for (int eye = 0; eye < 2; ++eye)
  {
    pose.eyes[eye].view = IdentityMatrix();
    pose.eyes[eye].view[12] = -(x + (eye == 0 ? -0.032 : 0.032));
    pose.eyes[eye].view[13] = -1.3;
    // HoloLens 2-like: about 29° vertical field of view, frustums slightly off-axis (nasal).
    pose.eyes[eye].projection = PerspectiveProjection(29.0, aspect, 0.1, 20.0);
    pose.eyes[eye].projection[8] = eye == 0 ? 0.03 : -0.03;
  }
  return pose;
}

struct Result
{
  std::string codec;
  int frames = 0;
  double seconds = 0.0;
  std::vector<double> latencies;
  double renderMs = 0.0, denoiseMs = 0.0, encodeMs = 0.0, decodeMs = 0.0, bytes = 0.0;
};

double Median(std::vector<double> values)
{
  if (values.empty())
  {
    return 0.0;
  }
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

bool RunCodec(vtkVolume* volume, vtkStereoSpatioTemporalDenoiser* denoiser, bool h264, int width,
  int height, int frames, Result* result)
{
  vtkNew<vtkHoloLensRemotingOutput> output;
  output->SetVolume(volume);
  output->SetDenoiser(denoiser);
  output->SetEyeSize(width, height);
  output->SetPort(0);
  output->SetLogConnections(false);
  output->SetMaximumStillFrames(0); // one frame per pose: the closed loop measures latency
  output->SetCodec(h264 ? vtkHoloLensRemotingOutput::CODEC_H264 : vtkHoloLensRemotingOutput::CODEC_JPEG);
  if (!output->Start())
  {
    return false;
  }
  result->codec = h264 ? "H.264" : "JPEG";
  std::atomic<bool> done{ false };
  std::atomic<int> received{ 0 };
  double decodeTotal = 0.0, bytesTotal = 0.0;
  std::vector<double> latencies;
  std::string failure;
  double firstMs = 0.0, lastMs = 0.0;
  const double aspect = static_cast<double>(width) / height;

  // The headset: runs on its own thread while the render loop runs here.
  std::thread headset([&] {
    RemotingClient client;
    std::string reason;
    if (!client.Connect("127.0.0.1", static_cast<unsigned short>(output->GetBoundPort()),
          std::string("/ws?token=") + output->GetAccessToken(), false, &reason))
    {
      failure = reason;
      done = true;
      return;
    }
    HelloMessage hello;
    hello.protocol = 1;
    hello.client = "holovolume-remoting-benchmark";
    hello.decodesH264 = h264;
    client.SendText(SerializeHello(hello), &reason);
    H264Decoder decoders[2];
    // Frame 0 warms up (encoder set-up, first allocation); it is not counted.
    for (int frame = 0; frame <= frames && failure.empty(); ++frame)
    {
      const std::uint64_t poseId = static_cast<std::uint64_t>(frame) + 1;
      const double sentMs = NowMs();
      client.SendText(SerializePose(HeadPose(poseId, aspect)), &reason);
      for (;;)
      {
        std::string message;
        const auto kind = client.Receive(&message, 120.0, &reason);
        if (kind == RemotingClient::Received::Text)
        {
          continue;
        }
        if (kind != RemotingClient::Received::Binary)
        {
          failure = "no frame: " + reason;
          break;
        }
        FrameHeader header;
        EyeImage eyes[2];
        if (!DecodeFrameMessage(message, &header, eyes, &reason))
        {
          failure = reason;
          break;
        }
        const double decodeStart = NowMs();
        for (int eye = 0; eye < 2; ++eye)
        {
          std::vector<unsigned char> rgb;
          int w = 0, h = 0;
          const std::string data(eyes[eye].data);
          const bool ok = header.codec == Codec::H264 ? decoders[eye].Decode(data, &rgb, &w, &h, &reason)
                                                      : DecodeJpeg(data, &rgb, &w, &h, &reason);
          if (!ok)
          {
            failure = reason;
          }
        }
        const double decodedMs = NowMs();
        if (header.poseId != poseId)
        {
          continue; // a frame for an older pose
        }
        if (frame > 0)
        {
          latencies.push_back(decodedMs - sentMs);
          decodeTotal += decodedMs - decodeStart;
          bytesTotal += static_cast<double>(eyes[0].data.size() + eyes[1].data.size());
          lastMs = decodedMs;
        }
        else
        {
          firstMs = decodedMs;
        }
        ++received;
        break;
      }
    }
    done = true;
  });

  double render = 0.0, denoise = 0.0, encode = 0.0;
  int published = 0;
  while (!done)
  {
    if (output->ProcessFrame(0.01) == 1)
    {
      if (published++ > 0)
      {
        render += output->GetLastRenderTime();
        denoise += output->GetLastDenoiseTime();
        encode += output->GetLastEncodeTime();
      }
      std::fprintf(stderr, "\r  %s: frame %d of %d", result->codec.c_str(), published, frames + 1);
    }
  }
  std::fprintf(stderr, "\n");
  headset.join();
  output->Stop();
  if (!failure.empty())
  {
    std::cerr << "holovolume-remoting-benchmark: " << failure << "\n";
    return false;
  }
  const int counted = static_cast<int>(latencies.size());
  result->frames = counted;
  result->seconds = (lastMs - firstMs) / 1000.0;
  result->latencies = latencies;
  const double n = std::max(1, published - 1);
  result->renderMs = render / n;
  result->denoiseMs = denoise / n;
  result->encodeMs = encode / n;
  result->decodeMs = decodeTotal / std::max(1, counted);
  result->bytes = bytesTotal / std::max(1, counted);
  return true;
}
}

int main(int argc, char* argv[])
{
  int width = 1440, height = 936, frames = 6;
  bool denoise = true;
  std::string volumePath = holovolume::DefaultVolume();
  std::string environmentPath = holovolume::DefaultEnvironment();
  for (int i = 1; i < argc; ++i)
  {
    const std::string argument = argv[i];
    const bool hasValue = i + 1 < argc;
    if (argument == "--eye-size" && hasValue)
    {
      if (std::sscanf(argv[++i], "%dx%d", &width, &height) != 2 || width < 2 || height < 2)
      {
        std::cerr << "holovolume-remoting-benchmark: --eye-size needs WIDTHxHEIGHT\n";
        return 2;
      }
    }
    else if (argument == "--frames" && hasValue)
      frames = holovolume::IntegerOption(
        "holovolume-remoting-benchmark", "--frames", argv[++i], 1, 100000);
    else if (argument == "--no-denoiser")
      denoise = false;
    else if (argument == "--volume" && hasValue)
      volumePath = argv[++i];
    else if (argument == "--environment" && hasValue)
      environmentPath = argv[++i];
    else if (argument == "-h" || argument == "--help")
    {
      std::cout << "Usage: holovolume-remoting-benchmark [--eye-size 1440x936] [--frames 6] "
                   "[--no-denoiser] [--volume FILE] [--environment FILE]\n\n"
                   "Streams the head MRI on localhost to a C++ client that plays the headset in closed\n"
                   "loop (pose -> frame for that pose -> decode -> next pose), once with JPEG and once\n"
                   "with H.264, and prints frames per second, pose-to-decoded latency and the server's\n"
                   "render, denoise and encode times per stereo frame.\n";
      return 0;
    }
    else
    {
      std::cerr << "holovolume-remoting-benchmark: unknown option '" << argument << "' (see --help)\n";
      return 2;
    }
  }
  vtkSmartPointer<vtkImageData> data = holovolume::ReadVolume(volumePath);
  if (!data)
  {
    std::cerr << "holovolume-remoting-benchmark: cannot read '" << volumePath
              << "' (apt-get install mricron-data for the default head)\n";
    return 1;
  }
  double range[2];
  data->GetScalarRange(range);
  vtkNew<vtkPathTracedVolumeMapper> mapper;
  mapper->SetInputData(data);
  vtkNew<vtkEnvironmentMapReader> environment;
  if (holovolume::FileExists(environmentPath))
  {
    environment->SetFileName(environmentPath.c_str());
    mapper->SetEnvironmentMapConnection(environment->GetOutputPort());
  }
  mapper->SetSamplesPerPixel(2);
  vtkNew<vtkVolumeProperty> property;
  holovolume::ApplyHeadMRIPreset(property, range[1] > 0 ? range[1] : 255.0);
  vtkNew<vtkVolume> volume;
  volume->SetMapper(mapper);
  volume->SetProperty(property);
  vtkNew<vtkStereoSpatioTemporalDenoiser> denoiser;

  std::printf("HoloVolume streaming on localhost: %dx%d per eye, 2 spp, %s, %d frames per codec "
              "after one warm-up frame, %d threads\n",
    width, height, denoise ? "denoised" : "raw", frames, std::max(1, static_cast<int>(std::thread::hardware_concurrency())));
  std::vector<Result> results;
  for (bool h264 : { false, true })
  {
    Result result;
    if (!RunCodec(volume, denoise ? denoiser.GetPointer() : nullptr, h264, width, height, frames, &result))
    {
      return 1;
    }
    results.push_back(result);
  }
  std::printf("\n%-6s %8s %12s %12s %9s %10s %9s %9s %11s\n", "codec", "fps", "pose->disp",
    "(median)", "render", "denoise", "encode", "decode", "KiB/frame");
  for (const Result& r : results)
  {
    double mean = 0.0;
    for (double latency : r.latencies)
    {
      mean += latency / r.latencies.size();
    }
    std::printf("%-6s %8.2f %9.0f ms %9.0f ms %6.0f ms %7.0f ms %6.1f ms %6.1f ms %11.0f\n",
      r.codec.c_str(), r.seconds > 0 ? (r.frames - 1) / r.seconds : 0.0, mean, Median(r.latencies),
      r.renderMs, r.denoiseMs, r.encodeMs, r.decodeMs, r.bytes / 1024.0);
  }
  std::printf("\npose->disp: from sending a pose to both eyes of the frame rendered for it decoded in "
              "the client (no display refresh included).\nrender/denoise/encode: the server's own times "
              "per stereo frame; encode includes tone mapping.\n");
  return 0;
}
