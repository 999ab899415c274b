// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Loopback: a C++ client drives vtkHoloLensRemotingOutput like the player page does and
// checks that every frame comes back rendered for the pose it sent, with that pose's own
// matrices. Geometry of the synthetic volume (0.235 m across, 0.6 m in front of the eyes,
// 60° vertical field of view, 64 x 48 pixels per eye) gives the expected image positions:
// - straight view: the volume's image centroid at x = 0.5 of the width (±0.08);
// - left projection with P[8] = 0.5 (an off-axis frustum, as a HoloLens reports): the left
//   eye's centroid moves to x = (1 - 0.5) / 2 = 0.25 (±0.08), the right eye's stays at 0.5;
// - looking away: (almost) nothing covered;
// - a grab moving the volume 0.1 m to the right: x_ndc shifts by (f / aspect) · 0.1 / 0.6 =
//   0.217, the centroid by 0.108 of the width;
// - a cutting plane through the centre keeping +x: about half the coverage, centroid to the right.
// Then interaction (illumination model, unknown names), H.264 with the denoiser, and a preset
// switch that the denoiser drops its history for by default and relights it for on request.
#include "PathTracingTestScene.h"
#include "vtkHoloLensRemotingOutput.h"
#include "vtkStereoSpatioTemporalDenoiser.h"

#include "vtkCallbackCommand.h"
#include "vtkDataArray.h"
#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkMath.h"
#include "vtkMatrix4x4.h"
#include "vtkPlaneCollection.h"

#include "hv/remoting/FrameCodec.h"
#include "hv/remoting/Protocol.h"
#include "hv/remoting/RemotingClient.h"

#include <cmath>
#include <iostream>
#include <vector>

namespace
{
using namespace hv::remoting;

int Failures = 0;
void Check(bool condition, const std::string& what)
{
  std::cout << (condition ? "ok: " : "FAILED: ") << what << "\n";
  Failures += condition ? 0 : 1;
}


// Eyes at (±0.032, 1.5, 0) looking along -z (or +z when lookingAway).
PoseMessage MakePose(std::uint64_t poseId, double leftOffAxis = 0.0, bool lookingAway = false)
{
  PoseMessage pose;
  pose.poseId = poseId;
  pose.mode = "immersive-vr";
  pose.head = IdentityMatrix();
  pose.head[13] = 1.5;
  for (int eye = 0; eye < 2; ++eye)
  {
    const double x = eye == 0 ? -0.032 : 0.032;
    Matrix4 view = IdentityMatrix();
    const double sign = lookingAway ? -1.0 : 1.0; // a half turn about y
    view[0] = view[10] = sign;
    view[12] = -sign * x;
    view[13] = -1.5;
    pose.eyes[eye].view = view;
    pose.eyes[eye].projection = PerspectiveProjection(60.0, 64.0 / 48.0, 0.05, 10.0);
  }
  pose.eyes[0].projection[8] = leftOffAxis;
  return pose;
}

struct EyeSummary
{
  double coverage = 0.0;  // fraction of pixels brighter than 20/255
  double centroidX = 0.0; // 0 = left edge, 1 = right edge
};

struct Frame
{
  FrameHeader header;
  EyeSummary eyes[2];
  bool valid = false;
};

EyeSummary Summarize(const std::vector<unsigned char>& rgb, int width, int height)
{
  EyeSummary summary;
  double weight = 0.0, weightedX = 0.0;
  int covered = 0;
  for (int y = 0; y < height; ++y)
  {
    for (int x = 0; x < width; ++x)
    {
      const unsigned char* p = &rgb[(static_cast<std::size_t>(y) * width + x) * 3];
      const double value = (p[0] + p[1] + p[2]) / 3.0;
      if (value > 20.0)
      {
        ++covered;
        weight += value;
        weightedX += value * (x + 0.5) / width;
      }
    }
  }
  summary.coverage = static_cast<double>(covered) / (width * height);
  summary.centroidX = weight > 0.0 ? weightedX / weight : -1.0;
  return summary;
}

class Viewer
{
public:
  bool Join(vtkHoloLensRemotingOutput* output, bool h264)
  {
    std::string reason;
    if (!this->Client.Connect("127.0.0.1", static_cast<unsigned short>(output->GetBoundPort()),
          std::string("/ws?token=") + output->GetAccessToken(), false, &reason))
    {
      std::cout << "connect: " << reason << "\n";
      return false;
    }
    HelloMessage hello;
    hello.protocol = 1;
    hello.client = "loopback";
    hello.decodesH264 = h264;
    this->Client.SendText(SerializeHello(hello), &reason);
    std::string message;
    ServerTextMessage text;
    while (this->Client.Receive(&message, 5.0, &reason) == RemotingClient::Received::Text)
    {
      if (ParseServerTextMessage(message, &text, &reason) && text.type == "welcome")
      {
        this->Welcome = text;
        return true;
      }
    }
    return false;
  }

  void Send(const std::string& text)
  {
    std::string reason;
    this->Client.SendText(text, &reason);
  }

  // Runs the render loop until a frame is published, then reads frames until one for the
  // given pose id arrives (or nothing more comes).
  Frame NextFrame(vtkHoloLensRemotingOutput* output, std::uint64_t poseId)
  {
    Frame frame;
    for (int attempt = 0; attempt < 40; ++attempt)
    {
      const int published = output->ProcessFrame(0.1);
      if (published < 0)
      {
        return frame;
      }
      std::string message, reason;
      RemotingClient::Received kind;
      while ((kind = this->Client.Receive(&message, published ? 5.0 : 0.05, &reason)) !=
        RemotingClient::Received::Timeout)
      {
        if (kind == RemotingClient::Received::Closed || kind == RemotingClient::Received::Failed)
        {
          return frame;
        }
        if (kind != RemotingClient::Received::Binary)
        {
          continue;
        }
        EyeImage eyes[2];
        if (!DecodeFrameMessage(message, &frame.header, eyes, &reason))
        {
          std::cout << "frame: " << reason << "\n";
          return frame;
        }
        for (int eye = 0; eye < 2; ++eye)
        {
          std::vector<unsigned char> rgb;
          int width = 0, height = 0;
          const std::string data(eyes[eye].data);
          const bool decoded = frame.header.codec == Codec::H264
            ? this->Decoders[eye].Decode(data, &rgb, &width, &height, &reason)
            : DecodeJpeg(data, &rgb, &width, &height, &reason);
          if (!decoded)
          {
            std::cout << "decode: " << reason << "\n";
            return frame;
          }
          frame.eyes[eye] = Summarize(rgb, width, height);
        }
        if (frame.header.poseId == poseId)
        {
          frame.valid = true;
          return frame;
        }
      }
    }
    return frame;
  }

  RemotingClient Client;
  ServerTextMessage Welcome;
  H264Decoder Decoders[2];
};

vtkSmartPointer<vtkVolume> MakeScene()
{
  vtkNew<vtkPathTracedVolumeMapper> mapper;
  mapper->SetInputData(pathtracingtest::MakeVolume());
  mapper->SetEnvironmentMapData(pathtracingtest::MakeSky());
  mapper->SetSamplesPerPixel(4);
  mapper->SetExposure(1.0);
  vtkNew<vtkVolumeProperty> property;
  pathtracingtest::ApplyTransferFunction(property);
  auto volume = vtkSmartPointer<vtkVolume>::New();
  volume->SetMapper(mapper);
  volume->SetProperty(property);
  return volume;
}

void Configure(vtkHoloLensRemotingOutput* output, vtkVolume* volume)
{
  output->SetVolume(volume);
  output->SetPort(0);
  output->SetEyeSize(64, 48);
  output->SetWorldUnitsPerMetre(100.0); // the synthetic volume is 23.5 units = 0.235 m across
  output->SetVolumeOrientation(vtkHoloLensRemotingOutput::ORIENTATION_AS_IS);
  output->SetInitialVolumeCenter(0.0, 1.5, -0.6);
  output->SetMaximumStillFrames(0);
}
}

int TestHoloLensRemotingOutput(int, char*[])
{
  vtkSmartPointer<vtkVolume> volume = MakeScene();
  vtkNew<vtkVolumeProperty> bonePreset;
  pathtracingtest::ApplyTransferFunction(bonePreset);
  vtkNew<vtkHoloLensRemotingOutput> output;
  Configure(output, volume);
  output->AddTransferFunctionPreset("soft", volume->GetProperty());
  output->AddTransferFunctionPreset("bone", bonePreset);
  if (!output->Start())
  {
    std::cout << "FAILED: the output did not start\n";
    return EXIT_FAILURE;
  }
  std::cout << "serving " << output->GetUrl() << "\n";
  Viewer viewer;
  Check(viewer.Join(output, false), "the viewer joins and gets a welcome");
  Check(viewer.Welcome.role == Role::Controller, "the first viewer controls");
  Check(viewer.Welcome.welcome.presets.size() == 2 && viewer.Welcome.welcome.preset == "soft",
    "the welcome lists the presets");
  Check(std::fabs(viewer.Welcome.welcome.volumeCenter[2] + 0.6) < 1e-9, "the welcome says where the volume is");

  const PoseMessage straight = MakePose(1);
  viewer.Send(SerializePose(straight));
  Frame frame = viewer.NextFrame(output, 1);
  Check(frame.valid, "a frame comes back for pose 1");
  bool sameMatrices = true;
  for (int eye = 0; eye < 2; ++eye)
  {
    for (int i = 0; i < 16; ++i)
    {
      sameMatrices = sameMatrices &&
        std::fabs(frame.header.eyes[eye].view[i] - straight.eyes[eye].view[i]) < 1e-12 &&
        std::fabs(frame.header.eyes[eye].projection[i] - straight.eyes[eye].projection[i]) < 1e-12;
    }
  }
  Check(sameMatrices, "the frame carries the pose's own view and projection matrices");
  std::cout << "  straight: coverage " << frame.eyes[0].coverage << ", centroid "
            << frame.eyes[0].centroidX << " / " << frame.eyes[1].centroidX << "\n";
  Check(frame.eyes[0].coverage > 0.02 && std::fabs(frame.eyes[0].centroidX - 0.5) < 0.08 &&
      std::fabs(frame.eyes[1].centroidX - 0.5) < 0.08,
    "straight view: the volume is in the middle of both eyes");
  const double straightCoverage = frame.eyes[0].coverage;

  viewer.Send(SerializePose(MakePose(2, 0.5)));
  frame = viewer.NextFrame(output, 2);
  std::cout << "  off-axis left: centroid " << frame.eyes[0].centroidX << " / " << frame.eyes[1].centroidX << "\n";
  Check(frame.valid && std::fabs(frame.eyes[0].centroidX - 0.25) < 0.08 &&
      std::fabs(frame.eyes[1].centroidX - 0.5) < 0.08,
    "an asymmetric left frustum moves only the left image, to x = 0.25");

  viewer.Send(SerializePose(MakePose(3, 0.0, true)));
  frame = viewer.NextFrame(output, 3);
  Check(frame.valid && frame.eyes[0].coverage < 0.001 && frame.eyes[1].coverage < 0.001,
    "looking away: no volume in view");

  // A pose older than the newest is ignored; the next frame is still for pose 3.
  viewer.Send(SerializePose(MakePose(2)));
  viewer.Send(R"({"type":"interaction","action":"grab-start"})");
  InteractionMessage grab;
  grab.action = InteractionAction::GrabMove;
  grab.transform = IdentityMatrix();
  grab.transform[12] = 0.1;
  viewer.Send(SerializeInteraction(grab));
  viewer.Send(R"({"type":"interaction","action":"grab-end"})");
  viewer.Send(SerializePose(MakePose(4)));
  frame = viewer.NextFrame(output, 4);
  std::cout << "  moved 0.1 m: centroid " << frame.eyes[0].centroidX << ", volume centre x "
            << frame.header.volumeCenter[0] << "\n";
  Check(frame.valid && std::fabs(frame.header.volumeCenter[0] - 0.1) < 1e-9,
    "a grab moves the volume 0.1 m (the frame reports its new centre)");
  Check(frame.valid && std::fabs(frame.eyes[0].centroidX - 0.608) < 0.06,
    "the moved volume appears 0.108 of the width to the right");

  InteractionMessage plane;
  plane.action = InteractionAction::CuttingPlane;
  plane.enabled = true;
  plane.origin = { 0.1, 1.5, -0.6 };
  plane.normal = { 1.0, 0.0, 0.0 };
  viewer.Send(SerializeInteraction(plane));
  frame = viewer.NextFrame(output, 4);
  std::cout << "  cut: coverage " << frame.eyes[0].coverage << " of " << straightCoverage << ", centroid "
            << frame.eyes[0].centroidX << "\n";
  Check(frame.valid && frame.eyes[0].coverage > 0.3 * straightCoverage &&
      frame.eyes[0].coverage < 0.75 * straightCoverage && frame.eyes[0].centroidX > 0.63,
    "a cutting plane through the centre keeps the +x half");
  Check(frame.valid && frame.header.cuttingPlane, "the frame says its cutting plane is on");
  plane.enabled = false;
  viewer.Send(SerializeInteraction(plane));
  viewer.Send(R"({"type":"interaction","action":"reset-placement"})");
  viewer.Send(SerializePose(MakePose(5)));
  frame = viewer.NextFrame(output, 5);
  Check(frame.valid && std::fabs(frame.header.volumeCenter[0]) < 1e-9 &&
      std::fabs(frame.eyes[0].coverage - straightCoverage) < 0.2 * straightCoverage,
    "reset placement and no cutting plane: the volume is back (interaction sent before a pose "
    "is in that pose's frame)");
  viewer.Send(R"({"type":"interaction","action":"illumination","model":"emission-absorption"})");
  viewer.Send(R"({"type":"interaction","action":"transfer-function","preset":"bone"})");
  viewer.Send(SerializePose(MakePose(6)));
  frame = viewer.NextFrame(output, 6);
  auto* mapper = vtkPathTracedVolumeMapper::SafeDownCast(volume->GetMapper());
  Check(frame.valid && mapper->GetIlluminationModel() == vtkPathTracedVolumeMapper::EMISSION_ABSORPTION &&
      volume->GetProperty() == bonePreset.GetPointer() && mapper->GetClippingPlanes()->GetNumberOfItems() == 0,
    "illumination model and transfer-function preset switched");
  Check(frame.valid && frame.header.illuminationModel == "emission-absorption" &&
      frame.header.preset == "bone" && !frame.header.cuttingPlane,
    "the frame names its illumination model and preset (the player's controls show them)");

  // A malformed message is refused and the stream goes on.
  viewer.Send(R"({"type":"pose","poseId":7})");
  viewer.Send(SerializePose(MakePose(8)));
  frame = viewer.NextFrame(output, 8);
  Check(frame.valid && output->GetNumberOfRejectedMessages() == 1, "a malformed pose is rejected, the next one renders");

  // A still pose and an unchanged scene render nothing (MaximumStillFrames is 0 here): what
  // the render itself touches does not count as a change.
  int idleFrames = 0;
  for (int i = 0; i < 4; ++i)
  {
    idleFrames += output->ProcessFrame(0.01);
  }
  Check(idleFrames == 0, "a still pose and an unchanged scene render nothing");
  // StartEvent comes with the newest head pose, before the output decides whether to render:
  // an environment map changed there (a live radiance map) is rendered in that very frame,
  // though the pose is still.
  struct LiveEnvironment
  {
    vtkHoloLensRemotingOutput* Output;
    vtkImageData* Map;
    int Calls = 0;
    bool ChangeNow = false;
    bool HasPose = false;
    double HeadY = 0.0;
  } live{ output, mapper->GetEnvironmentMap() };
  vtkNew<vtkCallbackCommand> onStart;
  onStart->SetClientData(&live);
  onStart->SetCallback(
    [](vtkObject*, unsigned long, void* clientData, void*)
    {
      auto* state = static_cast<LiveEnvironment*>(clientData);
      ++state->Calls;
      vtkNew<vtkMatrix4x4> head;
      state->HasPose = state->Output->GetHeadPose(head);
      state->HeadY = head->GetElement(1, 3);
      if (state->ChangeNow)
      {
        state->Map->Modified();
        state->ChangeNow = false;
      }
    });
  const unsigned long startObserver = output->AddObserver(vtkCommand::StartEvent, onStart);
  live.ChangeNow = true;
  const vtkTypeUInt64 frameBefore = output->GetFrameId();
  const int changedFrames = output->ProcessFrame(0.01);
  Check(changedFrames == 1 && output->GetFrameId() == frameBefore + 1 &&
      output->GetLastPoseId() == 8 && live.Calls == 1,
    "an environment map changed in StartEvent is rendered in the same step, for the still pose");
  Check(live.HasPose && std::fabs(live.HeadY - 150.0) < 1e-9,
    "GetHeadPose() gives the controller's head in world units (1.5 m at 100 units a metre)");
  idleFrames = 0;
  for (int i = 0; i < 3; ++i)
  {
    idleFrames += output->ProcessFrame(0.01);
  }
  Check(idleFrames == 0 && live.Calls == 4, "then the loop idles again, StartEvent on every step");
  // The head turned 30 degrees to its left (counter-clockwise seen from above) and 0.2 m to
  // the right: the pose is head to world, so the gaze (-Z of the head) points to -x and -z in
  // the world, the way vtkEnvironmentSyncedLight::SetHeadsetPose() takes a headset pose.
  PoseMessage turned = MakePose(9);
  const double turn = vtkMath::RadiansFromDegrees(30.0);
  turned.head[0] = turned.head[10] = std::cos(turn);
  turned.head[2] = -std::sin(turn); // column 0, the head's x axis in the world
  turned.head[8] = std::sin(turn);  // column 2, its z axis
  turned.head[12] = 0.2;
  viewer.Send(SerializePose(turned));
  frame = viewer.NextFrame(output, 9);
  vtkNew<vtkMatrix4x4> worldFromHead;
  const bool turnedPose = output->GetHeadPose(worldFromHead);
  double gaze[4] = { 0.0, 0.0, -1.0, 0.0 }, gazeInWorld[4];
  worldFromHead->MultiplyPoint(gaze, gazeInWorld);
  Check(frame.valid && turnedPose && std::fabs(gazeInWorld[0] + std::sin(turn)) < 1e-9 &&
      std::fabs(gazeInWorld[2] + std::cos(turn)) < 1e-9 &&
      std::fabs(worldFromHead->GetElement(0, 3) - 20.0) < 1e-9,
    "GetHeadPose() of a head turned 30 degrees left: the gaze points to (-sin 30, 0, -cos 30), "
    "the head 0.2 m = 20 units to the right");
  output->RemoveObserver(startObserver);
  std::cout << "  render " << output->GetLastRenderTime() << " ms, encode " << output->GetLastEncodeTime()
            << " ms, " << output->GetLastJpegBytes() << " JPEG bytes\n";
  output->Stop();

  // H.264 with the denoiser, a second output.
  vtkSmartPointer<vtkVolume> volume264 = MakeScene();
  vtkNew<vtkStereoSpatioTemporalDenoiser> denoiser;
  vtkNew<vtkHoloLensRemotingOutput> output264;
  Configure(output264, volume264);
  // A preset that differs from the scene's in its opacity alone, as the application's presets do.
  vtkNew<vtkVolumeProperty> densePreset;
  pathtracingtest::ApplyTransferFunction(densePreset);
  densePreset->SetScalarOpacityUnitDistance(0.25); // twice the extinction
  output264->AddTransferFunctionPreset("soft", volume264->GetProperty());
  output264->AddTransferFunctionPreset("dense", densePreset);
  output264->SetCodec(vtkHoloLensRemotingOutput::CODEC_H264);
  output264->SetDenoiser(denoiser);
  output264->SetMaximumStillFrames(3);
  Check(output264->Start() == 1, "an H.264 output starts");
  Viewer h264Viewer;
  Check(h264Viewer.Join(output264, true) && h264Viewer.Welcome.codec == Codec::H264,
    "a viewer that decodes H.264 gets H.264");
  h264Viewer.Send(SerializePose(MakePose(10)));
  frame = h264Viewer.NextFrame(output264, 10);
  Check(frame.valid && frame.header.keyFrame && frame.header.codecString.rfind("avc1.42", 0) == 0,
    "the first H.264 frame is a key frame of the baseline profile");
  Check(frame.valid && std::fabs(frame.eyes[0].centroidX - 0.5) < 0.08 && frame.eyes[0].coverage > 0.02,
    "the H.264 frame decodes to the volume in the middle");
  // Still frames keep coming for the denoiser to converge, as delta frames.
  const Frame still = h264Viewer.NextFrame(output264, 10);
  Check(still.valid && !still.header.keyFrame && still.header.frameId > frame.header.frameId,
    "a still view keeps converging with delta frames");
  Check(output264->GetLastDenoiseTime() > 0.0, "the denoiser runs on every frame");
  std::cout << "  H.264: " << output264->GetLastH264Bytes() << " bytes, denoise "
            << output264->GetLastDenoiseTime() << " ms\n";

  // A preset switch from the headset: the output swaps the volume's property, which the
  // denoiser sees as a new transfer function over the same data. By default it drops its
  // history; with RelightHistoryOnTransferFunctionChange (the application's setting) it keeps
  // it, relit. Each switch is followed by still frames, so that the history grows again.
  // Each denoised frame's mean history length and the property it was rendered with, recorded
  // as the denoiser finishes: the output renders still frames on its own, so that the one the
  // viewer receives need not be the last the denoiser ran.
  struct DenoisedFrame
  {
    vtkVolumeProperty* property;
    double meanHistoryLength;
  };
  struct Recorder
  {
    vtkStereoSpatioTemporalDenoiser* denoiser;
    vtkVolume* volume;
    std::vector<DenoisedFrame> frames;
  } recorder{ denoiser, volume264, {} };
  vtkNew<vtkCallbackCommand> record;
  record->SetClientData(&recorder);
  record->SetCallback(
    [](vtkObject*, unsigned long, void* clientData, void*)
    {
      auto* r = static_cast<Recorder*>(clientData);
      vtkDataArray* length =
        r->denoiser->GetEyeOutput(0)->GetFieldData()->GetArray("MeanHistoryLength");
      r->frames.push_back({ r->volume->GetProperty(), length ? length->GetTuple1(0) : -1.0 });
    });
  denoiser->AddObserver(vtkCommand::EndEvent, record);
  // The mean history length on the first frame rendered with the preset.
  const auto historyAfterSwitchTo =
    [&](const char* preset, vtkVolumeProperty* property, std::uint64_t poseId)
  {
    recorder.frames.clear();
    h264Viewer.Send(
      std::string(R"({"type":"interaction","action":"transfer-function","preset":")") + preset +
      R"("})");
    h264Viewer.Send(SerializePose(MakePose(poseId)));
    const Frame switched = h264Viewer.NextFrame(output264, poseId);
    Check(switched.valid && switched.header.preset == preset,
      std::string("the viewer switched to the preset '") + preset + "'");
    // Still frames, so that the history grows again before the next switch.
    for (int frame = 0; frame < 3; ++frame)
    {
      h264Viewer.NextFrame(output264, poseId);
    }
    for (const DenoisedFrame& frame : recorder.frames)
    {
      if (frame.property == property)
      {
        return frame.meanHistoryLength;
      }
    }
    return -1.0;
  };
  vtkVolumeProperty* softPreset = volume264->GetProperty();
  const double dropped = historyAfterSwitchTo("dense", densePreset, 11);
  denoiser->RelightHistoryOnTransferFunctionChangeOn();
  const double relit = historyAfterSwitchTo("soft", softPreset, 12);
  std::cout << "  mean history length on the frame of a preset switch: " << dropped
            << " frames dropped, " << relit << " relit\n";
  Check(dropped >= 0.0 && dropped <= 1.0, "by default a preset switch starts the history over");
  Check(
    relit > 1.5, "with RelightHistoryOnTransferFunctionChange a preset switch keeps the history");
  output264->Stop();
  return Failures == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
