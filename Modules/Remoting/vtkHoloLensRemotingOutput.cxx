// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "vtkHoloLensRemotingOutput.h"

#include "vtkPathTracedVolumeMapper.h"
#include "vtkStereoSpatioTemporalDenoiser.h"

#include "vtkAbstractVolumeMapper.h"
#include "vtkCommand.h"
#include "vtkDataObject.h"
#include "vtkImageData.h"
#include "vtkMatrix4x4.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPlane.h"
#include "vtkPointData.h"
#include "vtkSmartPointer.h"
#include "vtkUnsignedCharArray.h"
#include "vtkVolume.h"
#include "vtkVolumeProperty.h"

#include "hv/remoting/FrameCodec.h"
#include "hv/remoting/RemotingServer.h"

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <deque>
#include <iostream>
#include <mutex>
#include <string>
#include <vector>

vtkStandardNewMacro(vtkHoloLensRemotingOutput);
vtkCxxSetObjectMacro(vtkHoloLensRemotingOutput, Denoiser, vtkStereoSpatioTemporalDenoiser);

namespace
{
using hv::remoting::Matrix4;

double NowMs()
{
  using namespace std::chrono;
  return duration<double, std::milli>(steady_clock::now().time_since_epoch()).count();
}

const struct
{
  const char* name;
  int model;
} IlluminationModelNames[] = {
  { "path-traced", vtkPathTracedVolumeMapper::PATH_TRACED },
  { "emission-absorption", vtkPathTracedVolumeMapper::EMISSION_ABSORPTION },
  { "gradient-phong", vtkPathTracedVolumeMapper::GRADIENT_PHONG },
  { "prefiltered-environment", vtkPathTracedVolumeMapper::PREFILTERED_ENVIRONMENT },
};

const char* IlluminationModelName(int model)
{
  for (const auto& entry : IlluminationModelNames)
  {
    if (entry.model == model)
    {
      return entry.name;
    }
  }
  return "path-traced";
}

// Column-major (WebXR) to vtkMatrix4x4 (row-major element access).
void ToVTK(const Matrix4& m, vtkMatrix4x4* matrix)
{
  for (int row = 0; row < 4; ++row)
  {
    for (int column = 0; column < 4; ++column)
    {
      matrix->SetElement(row, column, m[column * 4 + row]);
    }
  }
}

// The world is the client's space scaled by s = world units per metre. With S = diag(s,s,s,1):
// a view becomes S·V·S⁻¹ (its translation scaled), a projection P·S⁻¹, and a transform that
// acts on points (a grab) S·D·S⁻¹.
Matrix4 ConjugateByScale(const Matrix4& m, double s)
{
  Matrix4 result = m;
  for (int row = 0; row < 3; ++row)
  {
    result[12 + row] *= s; // column 3, rows 0..2
  }
  for (int column = 0; column < 3; ++column)
  {
    result[column * 4 + 3] /= s; // row 3, columns 0..2
  }
  return result;
}

Matrix4 ProjectionToWorldUnits(const Matrix4& projection, double s)
{
  Matrix4 result = projection;
  for (int column = 0; column < 3; ++column)
  {
    for (int row = 0; row < 4; ++row)
    {
      result[column * 4 + row] /= s;
    }
  }
  return result;
}

// The determinant of the linear part: the cube of a placement's uniform scale.
double Determinant3(const Matrix4& m)
{
  return glm::determinant(glm::dmat3(glm::make_mat4(m.data())));
}

// What a frame shows besides the pose: the volume (its property and placement), its mapper and
// the data objects the mapper renders (the volume's data, the environment map).
vtkMTimeType SceneMTime(vtkVolume* volume)
{
  vtkMTimeType time = volume->GetMTime();
  if (vtkAbstractVolumeMapper* mapper = volume->GetMapper())
  {
    time = std::max(time, mapper->GetMTime());
    for (int port = 0; port < mapper->GetNumberOfInputPorts(); ++port)
    {
      if (mapper->GetNumberOfInputConnections(port) > 0)
      {
        if (vtkDataObject* data = mapper->GetInputDataObject(port, 0))
        {
          time = std::max(time, data->GetMTime());
        }
      }
    }
  }
  return time;
}
}

struct vtkHoloLensRemotingOutput::Internals
{
  std::unique_ptr<hv::remoting::RemotingServer> Server;
  std::string Url;
  std::string Token;
  std::vector<std::pair<std::string, vtkSmartPointer<vtkVolumeProperty>>> Presets;
  std::string CurrentPreset;

  Matrix4 InitialPlacement = hv::remoting::IdentityMatrix();
  Matrix4 Placement = hv::remoting::IdentityMatrix();
  Matrix4 GrabStartPlacement = hv::remoting::IdentityMatrix();
  bool Grabbing = false;
  double DataCenter[3] = { 0, 0, 0 };
  double DataRadius = 1.0;
  vtkNew<vtkMatrix4x4> PlacementMatrix;
  vtkNew<vtkPlane> CuttingPlane;
  bool CuttingPlaneOn = false;

  hv::remoting::PoseMessage Pose;
  bool HasPose = false;
  int StillFrames = 0;
  bool SceneChanged = true;
  // The scene's modification time when the last frame was rendered (see SceneMTime()).
  vtkMTimeType RenderedSceneMTime = 0;
  bool KeyFrameRequested = false;

  hv::remoting::H264Encoder H264[2];
  vtkNew<vtkImageData> Display[2];

  struct FrameTiming
  {
    double publishedMs, renderMs, denoiseMs, encodeMs;
  };
  std::deque<FrameTiming> Recent;
  double LastStatisticsMs = 0.0;
  std::atomic<bool> StopRequested{ false };
  std::mutex LogMutex;

  hv::remoting::WelcomeInfo Welcome(vtkHoloLensRemotingOutput* self) const
  {
    hv::remoting::WelcomeInfo info;
    info.server = "HoloVolume";
    info.eyeWidth = self->EyeSize[0];
    info.eyeHeight = self->EyeSize[1];
    for (const auto& entry : IlluminationModelNames)
    {
      info.illuminationModels.emplace_back(entry.name);
    }
    auto* mapper = vtkPathTracedVolumeMapper::SafeDownCast(self->Volume->GetMapper());
    info.illuminationModel = IlluminationModelName(mapper->GetIlluminationModel());
    for (const auto& preset : this->Presets)
    {
      info.presets.push_back(preset.first);
    }
    info.preset = this->CurrentPreset;
    this->VolumeCenterMetres(self->WorldUnitsPerMetre, info.volumeCenter.data());
    info.volumeRadius =
      this->DataRadius * std::cbrt(std::fabs(Determinant3(this->Placement))) / self->WorldUnitsPerMetre;
    return info;
  }

  void VolumeCenterMetres(double worldUnitsPerMetre, double center[3]) const
  {
    for (int row = 0; row < 3; ++row)
    {
      center[row] = (this->Placement[row] * this->DataCenter[0] + this->Placement[4 + row] * this->DataCenter[1] +
                      this->Placement[8 + row] * this->DataCenter[2] + this->Placement[12 + row]) /
        worldUnitsPerMetre;
    }
  }
};

vtkHoloLensRemotingOutput::vtkHoloLensRemotingOutput()
  : Internal(new Internals)
{
  this->SetBindAddress("127.0.0.1");
}

vtkHoloLensRemotingOutput::~vtkHoloLensRemotingOutput()
{
  this->Stop();
  this->SetVolume(nullptr);
  this->SetDenoiser(nullptr);
  this->SetBindAddress(nullptr);
  this->SetAccessToken(nullptr);
  this->SetCertificateFile(nullptr);
  this->SetPrivateKeyFile(nullptr);
  this->SetWebRoot(nullptr);
}

void vtkHoloLensRemotingOutput::SetVolume(vtkVolume* volume)
{
  if (this->Volume == volume)
  {
    return;
  }
  if (this->Volume)
  {
    this->Volume->UnRegister(this);
  }
  this->Volume = volume;
  if (this->Volume)
  {
    this->Volume->Register(this);
  }
  this->Modified();
}

void vtkHoloLensRemotingOutput::AddTransferFunctionPreset(const char* name, vtkVolumeProperty* property)
{
  if (!name || !*name || !property)
  {
    vtkErrorMacro("AddTransferFunctionPreset needs a name and a vtkVolumeProperty.");
    return;
  }
  this->Internal->Presets.emplace_back(name, property);
  this->Modified();
}

void vtkHoloLensRemotingOutput::RemoveAllTransferFunctionPresets()
{
  this->Internal->Presets.clear();
  this->Modified();
}

int vtkHoloLensRemotingOutput::Start()
{
  Internals& internal = *this->Internal;
  if (internal.Server && internal.Server->IsRunning())
  {
    return 1;
  }
  auto* mapper = this->Volume ? vtkPathTracedVolumeMapper::SafeDownCast(this->Volume->GetMapper()) : nullptr;
  if (!mapper)
  {
    vtkErrorMacro("Set a vtkVolume whose mapper is a vtkPathTracedVolumeMapper before Start().");
    return 0;
  }
  vtkDataSet* data = mapper->GetDataSetInput();
  if (!data || data->GetNumberOfPoints() == 0)
  {
    vtkErrorMacro("The volume's mapper has no input data; connect the volume image first.");
    return 0;
  }
  if (this->EyeSize[0] < 2 || this->EyeSize[1] < 2)
  {
    vtkErrorMacro("EyeSize must be at least 2 x 2 pixels.");
    return 0;
  }
  if (!this->WebRoot)
  {
    this->SetWebRoot(HOLOVOLUME_REMOTING_WEB_ROOT);
  }

  // Initial placement: the data centre at InitialVolumeCenter, oriented, in world units.
  double bounds[6];
  data->GetBounds(bounds);
  for (int i = 0; i < 3; ++i)
  {
    internal.DataCenter[i] = 0.5 * (bounds[2 * i] + bounds[2 * i + 1]);
  }
  internal.DataRadius = 0.5 *
    std::sqrt((bounds[1] - bounds[0]) * (bounds[1] - bounds[0]) + (bounds[3] - bounds[2]) * (bounds[3] - bounds[2]) +
      (bounds[5] - bounds[4]) * (bounds[5] - bounds[4]));
  Matrix4 rotation = hv::remoting::IdentityMatrix();
  if (this->VolumeOrientation == ORIENTATION_RAS)
  {
    // RAS to a y-up world facing the viewer at the origin: right → -x, superior → +y,
    // anterior → +z (towards the viewer, who looks along -z). A proper rotation (det +1).
    rotation = Matrix4{ -1, 0, 0, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 1 };
  }
  Matrix4 toOrigin = hv::remoting::IdentityMatrix();
  Matrix4 toCenter = hv::remoting::IdentityMatrix();
  for (int i = 0; i < 3; ++i)
  {
    toOrigin[12 + i] = -internal.DataCenter[i];
    toCenter[12 + i] = this->InitialVolumeCenter[i] * this->WorldUnitsPerMetre;
  }
  internal.InitialPlacement = hv::remoting::Multiply(toCenter, hv::remoting::Multiply(rotation, toOrigin));
  internal.Placement = internal.InitialPlacement;
  // The output owns the volume's placement: its own position, orientation and scale are reset.
  this->Volume->SetPosition(0, 0, 0);
  this->Volume->SetOrientation(0, 0, 0);
  this->Volume->SetScale(1.0);
  this->Volume->SetOrigin(0, 0, 0);
  ToVTK(internal.Placement, internal.PlacementMatrix);
  this->Volume->SetUserMatrix(internal.PlacementMatrix);

  if (internal.Presets.empty())
  {
    internal.Presets.emplace_back("initial", this->Volume->GetProperty());
  }
  internal.CurrentPreset = internal.Presets.front().first;
  for (const auto& preset : internal.Presets)
  {
    if (preset.second == this->Volume->GetProperty())
    {
      internal.CurrentPreset = preset.first;
    }
  }

  hv::remoting::ServerOptions options;
  options.bindAddress = this->BindAddress ? this->BindAddress : "127.0.0.1";
  options.port = static_cast<unsigned short>(this->Port);
  options.allowRemoteConnections = this->AllowRemoteConnections;
  options.accessToken = this->AccessToken ? this->AccessToken : "";
  options.certificateFile = this->CertificateFile ? this->CertificateFile : "";
  options.privateKeyFile = this->PrivateKeyFile ? this->PrivateKeyFile : "";
  options.webRoot = this->WebRoot;
  options.maximumMessageBytes = static_cast<std::size_t>(this->MaximumMessageSize);
  options.maximumFramesInFlight = this->MaximumFramesInFlight;
  options.codec = this->Codec == CODEC_H264 ? hv::remoting::Codec::H264 : hv::remoting::Codec::Jpeg;
  if (this->LogConnections)
  {
    options.log = [&internal](const std::string& line) {
      std::lock_guard<std::mutex> lock(internal.LogMutex);
      std::cerr << "HoloVolume remoting: " << line << std::endl;
    };
  }
  try
  {
    internal.Server = std::make_unique<hv::remoting::RemotingServer>(options);
  }
  catch (const std::exception& error)
  {
    vtkErrorMacro("Cannot create the server: " << error.what());
    return 0;
  }
  internal.Server->SetWelcome(internal.Welcome(this));
  std::string reason;
  if (!internal.Server->Start(&reason))
  {
    vtkErrorMacro("Cannot start serving: " << reason);
    internal.Server.reset();
    return 0;
  }
  internal.Url = internal.Server->GetUrl();
  internal.Token = internal.Server->GetAccessToken();
  internal.HasPose = false;
  internal.SceneChanged = true;
  internal.StillFrames = 0;
  internal.StopRequested = false;
  return 1;
}

void vtkHoloLensRemotingOutput::Stop()
{
  if (this->Internal->Server)
  {
    this->Internal->Server->Stop();
    this->Internal->Server.reset();
  }
}

bool vtkHoloLensRemotingOutput::IsRunning() const
{
  return this->Internal->Server && this->Internal->Server->IsRunning();
}

const char* vtkHoloLensRemotingOutput::GetUrl()
{
  return this->Internal->Url.c_str();
}

const char* vtkHoloLensRemotingOutput::GetAccessToken()
{
  return this->Internal->Token.c_str();
}

int vtkHoloLensRemotingOutput::GetBoundPort() const
{
  return this->IsRunning() ? this->Internal->Server->GetPort() : 0;
}

void vtkHoloLensRemotingOutput::RequestStop()
{
  this->Internal->StopRequested = true;
}

void vtkHoloLensRemotingOutput::GetVolumePlacement(vtkMatrix4x4* placement)
{
  if (placement)
  {
    ToVTK(this->Internal->Placement, placement);
  }
}

bool vtkHoloLensRemotingOutput::GetHeadPose(vtkMatrix4x4* worldFromHead)
{
  Internals& internal = *this->Internal;
  if (!worldFromHead || !internal.HasPose)
  {
    return false;
  }
  ToVTK(ConjugateByScale(internal.Pose.head, this->WorldUnitsPerMetre), worldFromHead);
  return true;
}

int vtkHoloLensRemotingOutput::GetNumberOfClients()
{
  return this->IsRunning() ? this->Internal->Server->GetCounters().clients : 0;
}

vtkTypeUInt64 vtkHoloLensRemotingOutput::GetNumberOfPosesReceived()
{
  return this->IsRunning() ? this->Internal->Server->GetCounters().posesReceived : 0;
}

vtkTypeUInt64 vtkHoloLensRemotingOutput::GetNumberOfRejectedMessages()
{
  return this->IsRunning() ? this->Internal->Server->GetCounters().rejectedMessages : 0;
}

vtkTypeUInt64 vtkHoloLensRemotingOutput::GetNumberOfDroppedFrames()
{
  return this->IsRunning() ? this->Internal->Server->GetCounters().droppedFrames : 0;
}

double vtkHoloLensRemotingOutput::GetPoseToDisplayTime()
{
  return this->IsRunning() ? this->Internal->Server->GetCounters().poseToDisplayMs : 0.0;
}

int vtkHoloLensRemotingOutput::ProcessFrame(double waitSeconds)
{
  Internals& internal = *this->Internal;
  if (!this->IsRunning())
  {
    vtkErrorMacro("Start() the output before processing frames.");
    return -1;
  }
  hv::remoting::RemotingServer& server = *internal.Server;
  auto* mapper = vtkPathTracedVolumeMapper::SafeDownCast(this->Volume->GetMapper());
  const double s = this->WorldUnitsPerMetre;

  // 1. The newest pose, then the interaction queued so far: the client's messages arrive in
  // order, so whatever it sent before this pose is applied to the frame rendered for it.
  hv::remoting::PoseMessage pose;
  if (server.TakeNewestPose(&pose))
  {
    internal.Pose = pose;
    internal.HasPose = true;
    internal.SceneChanged = true;
  }
  bool welcomeChanged = false;
  for (const hv::remoting::InteractionMessage& interaction : server.TakeInteractions())
  {
    using Action = hv::remoting::InteractionAction;
    switch (interaction.action)
    {
      case Action::GrabStart:
        internal.Grabbing = true;
        internal.GrabStartPlacement = internal.Placement;
        break;
      case Action::GrabMove:
      {
        if (!internal.Grabbing)
        {
          internal.Grabbing = true;
          internal.GrabStartPlacement = internal.Placement;
        }
        Matrix4 delta = ConjugateByScale(interaction.transform, s);
        // Keep the size within [0.1, 10] of the initial one.
        const double initialScale = std::cbrt(std::fabs(Determinant3(internal.InitialPlacement)));
        const double startScale = std::cbrt(std::fabs(Determinant3(internal.GrabStartPlacement)));
        const double deltaScale = std::cbrt(std::fabs(Determinant3(delta)));
        const double wanted = startScale * deltaScale / initialScale;
        const double clamped = std::min(10.0, std::max(0.1, wanted));
        if (wanted > 0.0 && clamped != wanted)
        {
          for (int column = 0; column < 3; ++column)
          {
            for (int row = 0; row < 3; ++row)
            {
              delta[column * 4 + row] *= clamped / wanted;
            }
          }
        }
        internal.Placement = hv::remoting::Multiply(delta, internal.GrabStartPlacement);
        internal.SceneChanged = true;
        welcomeChanged = true;
        break;
      }
      case Action::GrabEnd:
        internal.Grabbing = false;
        break;
      case Action::ResetPlacement:
        internal.Placement = internal.InitialPlacement;
        internal.Grabbing = false;
        internal.SceneChanged = true;
        welcomeChanged = true;
        break;
      case Action::CuttingPlane:
        if (internal.CuttingPlaneOn)
        {
          mapper->RemoveClippingPlane(internal.CuttingPlane);
        }
        internal.CuttingPlaneOn = interaction.enabled;
        if (interaction.enabled)
        {
          internal.CuttingPlane->SetOrigin(
            interaction.origin[0] * s, interaction.origin[1] * s, interaction.origin[2] * s);
          internal.CuttingPlane->SetNormal(interaction.normal.data());
          mapper->AddClippingPlane(internal.CuttingPlane);
        }
        if (this->Denoiser)
        {
          this->Denoiser->ResetHistory(); // newly exposed surfaces have no history
        }
        internal.SceneChanged = true;
        break;
      case Action::Illumination:
      {
        bool known = false;
        for (const auto& entry : IlluminationModelNames)
        {
          if (interaction.name == entry.name)
          {
            known = true;
            if (mapper->GetIlluminationModel() != entry.model)
            {
              mapper->SetIlluminationModel(entry.model);
              if (this->Denoiser)
              {
                this->Denoiser->ResetHistory();
              }
              internal.SceneChanged = true;
              welcomeChanged = true;
            }
          }
        }
        if (!known)
        {
          vtkWarningMacro("The viewer asked for an unknown illumination model '" << interaction.name << "'.");
        }
        break;
      }
      case Action::TransferFunction:
      {
        bool known = false;
        for (const auto& preset : internal.Presets)
        {
          if (interaction.name == preset.first)
          {
            known = true;
            if (internal.CurrentPreset != preset.first)
            {
              // A new property changes the mapper's classification stamp: the denoiser resets.
              this->Volume->SetProperty(preset.second);
              internal.CurrentPreset = preset.first;
              internal.SceneChanged = true;
              welcomeChanged = true;
            }
          }
        }
        if (!known)
        {
          vtkWarningMacro("The viewer asked for an unknown transfer-function preset '" << interaction.name << "'.");
        }
        break;
      }
    }
  }
  if (welcomeChanged)
  {
    ToVTK(internal.Placement, internal.PlacementMatrix);
    this->Volume->SetUserMatrix(internal.PlacementMatrix);
    server.SetWelcome(internal.Welcome(this));
  }

  const hv::remoting::ServerCounters counters = server.GetCounters();
  if (!counters.hasController)
  {
    internal.HasPose = false;
  }
  // Observers change the scene for this frame here (a live environment, say); whatever changed
  // since the last frame is rendered, as a new pose is.
  this->InvokeEvent(vtkCommand::StartEvent);
  if (SceneMTime(this->Volume) > internal.RenderedSceneMTime)
  {
    internal.SceneChanged = true;
  }
  const bool canRender = counters.clients > 0 && (internal.HasPose || !counters.hasController);
  // Taken once: an H.264 client that joined or lost a frame needs a key frame, even of a still view.
  const bool keyFrameRequested = server.TakeKeyFrameRequest();
  const bool wantsFrame =
    internal.SceneChanged || internal.StillFrames < this->MaximumStillFrames || keyFrameRequested;
  if (!canRender || !wantsFrame)
  {
    if (keyFrameRequested)
    {
      internal.KeyFrameRequested = true; // kept for the next frame
    }
    server.WaitForActivity(waitSeconds);
    return 0;
  }
  if (internal.SceneChanged)
  {
    internal.StillFrames = 0;
  }
  internal.SceneChanged = false;
  ++internal.StillFrames;

  // 2. Matrices: the controller's pose, or a default view for spectators without one.
  hv::remoting::EyeMatrices eyes[2];
  std::uint64_t poseId = 0;
  if (internal.HasPose)
  {
    eyes[0] = internal.Pose.eyes[0];
    eyes[1] = internal.Pose.eyes[1];
    poseId = internal.Pose.poseId;
  }
  else
  {
    double center[3];
    internal.VolumeCenterMetres(s, center);
    for (int eye = 0; eye < 2; ++eye)
    {
      const double position[3] = { eye == 0 ? -0.032 : 0.032, 1.6, 0.0 };
      const glm::dmat4 view = glm::lookAt(glm::make_vec3(position), glm::make_vec3(center), glm::dvec3(0, 1, 0));
      std::copy_n(glm::value_ptr(view), 16, eyes[eye].view.begin());
      eyes[eye].projection =
        hv::remoting::PerspectiveProjection(60.0, static_cast<double>(this->EyeSize[0]) / this->EyeSize[1], 0.05, 20.0);
    }
  }
  vtkNew<vtkMatrix4x4> views[2], projections[2];
  for (int eye = 0; eye < 2; ++eye)
  {
    ToVTK(ConjugateByScale(eyes[eye].view, s), views[eye]);
    ToVTK(ProjectionToWorldUnits(eyes[eye].projection, s), projections[eye]);
  }

  // 3. Render, denoise, tone-map. With a denoiser every frame is a fresh 2-spp estimate: the
  // denoiser accumulates over time instead of the mapper (as in a render window).
  if (this->Denoiser)
  {
    mapper->ProgressiveAccumulationOff();
  }
  const double renderStart = NowMs();
  if (!mapper->RenderStereoFrame(this->Volume, views[0], projections[0], views[1], projections[1],
        this->EyeSize[0], this->EyeSize[1], nullptr))
  {
    vtkErrorMacro("The mapper could not render the frame; see its error above.");
    return -1;
  }
  // After the render, which brings the mapper's inputs up to date: the next frame compares
  // with the scene as rendered.
  internal.RenderedSceneMTime = SceneMTime(this->Volume);
  const double denoiseStart = NowMs();
  vtkImageData* radiance[2] = { mapper->GetEyeOutput(0), mapper->GetEyeOutput(1) };
  if (this->Denoiser)
  {
    this->Denoiser->SetInputData(0, radiance[0]);
    this->Denoiser->SetInputData(1, radiance[1]);
    this->Denoiser->Update();
    radiance[0] = this->Denoiser->GetEyeOutput(0);
    radiance[1] = this->Denoiser->GetEyeOutput(1);
  }
  const double encodeStart = NowMs();
  hv::remoting::RGBAImageView images[2];
  for (int eye = 0; eye < 2; ++eye)
  {
    if (!mapper->ComputeDisplayImage(radiance[eye], internal.Display[eye]))
    {
      return -1;
    }
    auto* pixels = vtkUnsignedCharArray::SafeDownCast(internal.Display[eye]->GetPointData()->GetScalars());
    images[eye] = { pixels->GetPointer(0), this->EyeSize[0], this->EyeSize[1], true };
  }

  // 4. Encode for the codecs connected clients use, and publish.
  hv::remoting::FrameHeader header;
  header.frameId = ++this->FrameId;
  header.poseId = poseId;
  header.width = this->EyeSize[0];
  header.height = this->EyeSize[1];
  header.serverTimeMs = renderStart;
  header.renderMs = denoiseStart - renderStart;
  header.denoiseMs = encodeStart - denoiseStart;
  internal.VolumeCenterMetres(s, header.volumeCenter.data());
  header.eyes[0] = eyes[0];
  header.eyes[1] = eyes[1];
  header.illuminationModel = IlluminationModelName(mapper->GetIlluminationModel());
  header.preset = internal.CurrentPreset;
  header.cuttingPlane = internal.CuttingPlaneOn;
  std::string reason;
  std::string encoded[2];
  hv::remoting::PublishedFrame frame;
  frame.frameId = header.frameId;
  this->LastJpegBytes = this->LastH264Bytes = 0;
  if (server.NeedsCodec(hv::remoting::Codec::Jpeg))
  {
    const hv::remoting::JpegEncoder jpeg(this->JpegQuality);
    for (int eye = 0; eye < 2; ++eye)
    {
      if (!jpeg.Encode(images[eye], &encoded[eye], &reason))
      {
        vtkErrorMacro(<< reason);
        return -1;
      }
      this->LastJpegBytes += encoded[eye].size();
    }
    header.codec = hv::remoting::Codec::Jpeg;
    header.keyFrame = true;
    header.encodeMs = NowMs() - encodeStart;
    frame.jpegMessage = std::make_shared<const std::string>(
      hv::remoting::EncodeFrameMessage(header, encoded[0], encoded[1]));
  }
  if (server.NeedsCodec(hv::remoting::Codec::H264))
  {
    bool forceKey = keyFrameRequested || internal.KeyFrameRequested;
    internal.KeyFrameRequested = false;
    bool keyFrames[2] = { false, false };
    for (int eye = 0; eye < 2; ++eye)
    {
      hv::remoting::H264Encoder& encoder = internal.H264[eye];
      if (!encoder.IsOpen() || encoder.GetWidth() != ((this->EyeSize[0] + 1) & ~1) ||
        encoder.GetHeight() != ((this->EyeSize[1] + 1) & ~1))
      {
        // The rate is given for 60 Hz; a key frame every 2 s bounds how long a client that
        // missed one waits even if no key frame is requested.
        if (!encoder.Open(this->EyeSize[0], this->EyeSize[1], 60, this->H264BitRate, 120, &reason))
        {
          vtkErrorMacro(<< reason);
          return -1;
        }
        forceKey = true;
      }
    }
    for (int eye = 0; eye < 2; ++eye)
    {
      if (!internal.H264[eye].Encode(images[eye], forceKey, &encoded[eye], &keyFrames[eye], &reason))
      {
        vtkErrorMacro(<< reason);
        return -1;
      }
      this->LastH264Bytes += encoded[eye].size();
    }
    header.codec = hv::remoting::Codec::H264;
    header.keyFrame = keyFrames[0] && keyFrames[1];
    header.codecString = internal.H264[0].GetCodecString();
    header.encodeMs = NowMs() - encodeStart;
    frame.h264Message = std::make_shared<const std::string>(
      hv::remoting::EncodeFrameMessage(header, encoded[0], encoded[1]));
    frame.h264KeyFrame = header.keyFrame;
  }
  const double publishedMs = NowMs();
  server.Publish(frame);
  this->LastPoseId = poseId;
  this->LastRenderTime = header.renderMs;
  this->LastDenoiseTime = header.denoiseMs;
  this->LastEncodeTime = publishedMs - encodeStart;

  // 5. Statistics: running means over the last second, sent about twice a second.
  internal.Recent.push_back({ publishedMs, header.renderMs, header.denoiseMs, this->LastEncodeTime });
  while (!internal.Recent.empty() && internal.Recent.front().publishedMs < publishedMs - 1000.0)
  {
    internal.Recent.pop_front();
  }
  if (publishedMs - internal.LastStatisticsMs >= 500.0)
  {
    hv::remoting::ServerStatistics statistics;
    statistics.frameId = this->FrameId;
    const double span = internal.Recent.size() > 1
      ? internal.Recent.back().publishedMs - internal.Recent.front().publishedMs
      : 0.0;
    statistics.framesPerSecond =
      span > 0.0 ? 1000.0 * (internal.Recent.size() - 1) / span : 1000.0 / std::max(1.0, publishedMs - renderStart);
    for (const auto& timing : internal.Recent)
    {
      statistics.renderMs += timing.renderMs / internal.Recent.size();
      statistics.denoiseMs += timing.denoiseMs / internal.Recent.size();
      statistics.encodeMs += timing.encodeMs / internal.Recent.size();
    }
    server.PublishStatistics(statistics);
    internal.LastStatisticsMs = publishedMs;
  }
  this->InvokeEvent(vtkCommand::UpdateDataEvent);
  return 1;
}

int vtkHoloLensRemotingOutput::Run(double durationSeconds, int maximumFrames)
{
  if (!this->IsRunning() && !this->Start())
  {
    return -1;
  }
  const double start = NowMs();
  int published = 0;
  this->Internal->StopRequested = false;
  while (!this->Internal->StopRequested)
  {
    if (durationSeconds > 0.0 && NowMs() - start >= durationSeconds * 1000.0)
    {
      break;
    }
    if (maximumFrames > 0 && published >= maximumFrames)
    {
      break;
    }
    const int result = this->ProcessFrame(0.05);
    if (result < 0)
    {
      return -1;
    }
    published += result;
  }
  return published;
}

void vtkHoloLensRemotingOutput::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Volume: " << this->Volume << "\n";
  os << indent << "Denoiser: " << this->Denoiser << "\n";
  os << indent << "InitialVolumeCenter: " << this->InitialVolumeCenter[0] << ", "
     << this->InitialVolumeCenter[1] << ", " << this->InitialVolumeCenter[2] << "\n";
  os << indent << "WorldUnitsPerMetre: " << this->WorldUnitsPerMetre << "\n";
  os << indent << "VolumeOrientation: " << (this->VolumeOrientation == ORIENTATION_RAS ? "RAS" : "AsIs") << "\n";
  os << indent << "EyeSize: " << this->EyeSize[0] << " x " << this->EyeSize[1] << "\n";
  os << indent << "MaximumStillFrames: " << this->MaximumStillFrames << "\n";
  os << indent << "BindAddress: " << (this->BindAddress ? this->BindAddress : "(none)") << "\n";
  os << indent << "Port: " << this->Port << "\n";
  os << indent << "AllowRemoteConnections: " << this->AllowRemoteConnections << "\n";
  os << indent << "AccessToken: " << (this->AccessToken ? "(set)" : "(random)") << "\n";
  os << indent << "CertificateFile: " << (this->CertificateFile ? this->CertificateFile : "(none)") << "\n";
  os << indent << "PrivateKeyFile: " << (this->PrivateKeyFile ? this->PrivateKeyFile : "(none)") << "\n";
  os << indent << "WebRoot: " << (this->WebRoot ? this->WebRoot : "(default)") << "\n";
  os << indent << "Codec: " << (this->Codec == CODEC_H264 ? "H.264" : "JPEG") << "\n";
  os << indent << "JpegQuality: " << this->JpegQuality << "\n";
  os << indent << "H264BitRate: " << this->H264BitRate << "\n";
  os << indent << "MaximumFramesInFlight: " << this->MaximumFramesInFlight << "\n";
  os << indent << "MaximumMessageSize: " << this->MaximumMessageSize << "\n";
  os << indent << "LogConnections: " << this->LogConnections << "\n";
  os << indent << "Running: " << this->IsRunning() << "\n";
  os << indent << "FrameId: " << this->FrameId << "\n";
  os << indent << "LastPoseId: " << this->LastPoseId << "\n";
  os << indent << "LastRenderTime: " << this->LastRenderTime << " ms\n";
  os << indent << "LastDenoiseTime: " << this->LastDenoiseTime << " ms\n";
  os << indent << "LastEncodeTime: " << this->LastEncodeTime << " ms\n";
}
