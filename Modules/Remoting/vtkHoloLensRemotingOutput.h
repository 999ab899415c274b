// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
/**
 * @class vtkHoloLensRemotingOutput
 * @brief Streams stereo path-traced renders to a WebXR player (HoloLens 2 browser, any WebXR
 * headset, or a desktop browser) and takes head pose and interaction back.
 *
 * The output serves the player page (Modules/Remoting/web) and speaks the protocol of
 * Documentation/RemotingProtocol.md over one WebSocket. Each ProcessFrame() takes the
 * controller's newest pose, renders both eyes with the client's own view and projection
 * matrices (vtkPathTracedVolumeMapper::RenderStereoFrame, so asymmetric frustums are exact),
 * runs the denoiser when one is set, tone-maps, encodes (JPEG, or H.264 for clients that
 * decode it) and publishes the frame. Latest wins: a client still receiving an older frame
 * gets only the newest one next, and rendering never waits for a client.
 *
 * World coordinates: the client's XR reference space (`local-floor`, metres, +Y up) scaled
 * by WorldUnitsPerMetre (1000: the renderer works in millimetres, like medical volumes). The
 * volume is placed InitialVolumeCenter metres from the floor origin, oriented by
 * VolumeOrientation, and then follows grab/move/rotate/scale interaction; the environment
 * map keeps +Y up in that world (set the mapper's EnvironmentToWorldMatrix for a yaw).
 *
 * Security: the server listens on 127.0.0.1 unless AllowRemoteConnections is on, always
 * needs the access token it prints (random unless AccessToken is set), and serves HTTPS/WSS
 * when CertificateFile and PrivateKeyFile are set (a headset needs that: WebXR wants a secure
 * context off localhost).
 *
 * Each ProcessFrame() invokes vtkCommand::StartEvent once the newest pose and the interaction
 * are taken and before it decides whether to render: the place to change the scene for this
 * frame, e.g. a live environment map that follows the headset's pose (GetHeadPose()). A change
 * of the volume, its property, the mapper or the mapper's inputs (the data, the environment
 * map) since the last frame is rendered even when the pose is still, like a new pose.
 * Each published frame invokes vtkCommand::UpdateDataEvent; the timings of the last frame and
 * the server's counters are available through getters.
 */
#ifndef vtkHoloLensRemotingOutput_h
#define vtkHoloLensRemotingOutput_h

#include "holoRemotingModule.h"

#include "vtkObject.h"

#include <memory>

class vtkMatrix4x4;
class vtkStereoSpatioTemporalDenoiser;
class vtkVolume;
class vtkVolumeProperty;

class HOLOREMOTING_EXPORT vtkHoloLensRemotingOutput : public vtkObject
{
public:
  static vtkHoloLensRemotingOutput* New();
  vtkTypeMacro(vtkHoloLensRemotingOutput, vtkObject);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  enum Codecs
  {
    CODEC_JPEG = 0,
    CODEC_H264 = 1
  };
  enum VolumeOrientations
  {
    /// Data axes are world axes (+Y of the data is up).
    ORIENTATION_AS_IS = 0,
    /// RAS data (NIfTI, DICOM patient space): superior up, anterior facing the viewer.
    ORIENTATION_RAS = 1
  };

  ///@{
  /**
   * The volume to stream; its mapper must be a vtkPathTracedVolumeMapper. The output sets
   * the volume's UserMatrix (placement) and its property (transfer-function presets) and
   * the mapper's clipping planes (cutting plane) and illumination model.
   */
  void SetVolume(vtkVolume* volume);
  vtkGetObjectMacro(Volume, vtkVolume);
  ///@}

  ///@{
  /**
   * Optional denoiser, run on every frame (both eyes, with the mapper's auxiliary buffers).
   * With one, the mapper's progressive accumulation is switched off: the denoiser
   * accumulates over time instead.
   */
  void SetDenoiser(vtkStereoSpatioTemporalDenoiser* denoiser);
  vtkGetObjectMacro(Denoiser, vtkStereoSpatioTemporalDenoiser);
  ///@}

  /**
   * Adds a named transfer-function preset the viewer can switch to (the property is used
   * as is, not copied). The volume's property at Start() is offered as "initial" when no
   * preset is added.
   */
  void AddTransferFunctionPreset(const char* name, vtkVolumeProperty* property);
  void RemoveAllTransferFunctionPresets();

  ///@{
  /** Where the volume's centre starts, in the client's world (metres). Default (0, 1.3, -0.7). */
  vtkSetVector3Macro(InitialVolumeCenter, double);
  vtkGetVector3Macro(InitialVolumeCenter, double);
  ///@}

  ///@{
  /** World units per metre of the client's world (1000 for volumes in millimetres). */
  vtkSetClampMacro(WorldUnitsPerMetre, double, 1e-6, 1e9);
  vtkGetMacro(WorldUnitsPerMetre, double);
  ///@}

  ///@{
  /** How the data axes map to the world (default RAS, for medical volumes). */
  vtkSetClampMacro(VolumeOrientation, int, ORIENTATION_AS_IS, ORIENTATION_RAS);
  vtkGetMacro(VolumeOrientation, int);
  ///@}

  ///@{
  /** Per-eye render size in pixels (default 1440 x 936, the HoloLens 2's). */
  vtkSetVector2Macro(EyeSize, int);
  vtkGetVector2Macro(EyeSize, int);
  ///@}

  ///@{
  /**
   * Frames rendered for an unchanged pose and scene, so the denoiser (or the mapper's
   * progressive accumulation) converges; after that the loop idles. Default 32.
   */
  vtkSetClampMacro(MaximumStillFrames, int, 0, VTK_INT_MAX);
  vtkGetMacro(MaximumStillFrames, int);
  ///@}

  ///@{
  /** Server settings (read by Start()). */
  vtkSetStringMacro(BindAddress);
  vtkGetStringMacro(BindAddress);
  vtkSetClampMacro(Port, int, 0, 65535);
  vtkGetMacro(Port, int);
  vtkSetMacro(AllowRemoteConnections, bool);
  vtkGetMacro(AllowRemoteConnections, bool);
  vtkBooleanMacro(AllowRemoteConnections, bool);
  /** Empty or unset: a random 128-bit token. At least 16 characters otherwise. */
  vtkSetStringMacro(AccessToken);
  vtkSetStringMacro(CertificateFile);
  vtkGetStringMacro(CertificateFile);
  vtkSetStringMacro(PrivateKeyFile);
  vtkGetStringMacro(PrivateKeyFile);
  /** The player page's directory; default: the one shipped with the module. */
  vtkSetStringMacro(WebRoot);
  vtkGetStringMacro(WebRoot);
  vtkSetClampMacro(Codec, int, CODEC_JPEG, CODEC_H264);
  vtkGetMacro(Codec, int);
  vtkSetClampMacro(JpegQuality, int, 1, 100);
  vtkGetMacro(JpegQuality, int);
  /** Target H.264 bit rate per eye, bits per second, at 60 frames per second. */
  vtkSetClampMacro(H264BitRate, int, 100000, VTK_INT_MAX);
  vtkGetMacro(H264BitRate, int);

  /**
   * Flow control for clients that acknowledge decoded frames (the player does): at most this
   * many frames sent and not yet acknowledged per client; the newest frame waits for room.
   * Default 2: one decoding while the next travels. Takes effect at Start().
   */
  vtkSetClampMacro(MaximumFramesInFlight, int, 1, 16);
  vtkGetMacro(MaximumFramesInFlight, int);
  vtkSetClampMacro(MaximumMessageSize, int, 1024, 16 << 20);
  vtkGetMacro(MaximumMessageSize, int);
  /** Print connections, rejected requests and messages to stderr (on by default). */
  vtkSetMacro(LogConnections, bool);
  vtkGetMacro(LogConnections, bool);
  ///@}

  /**
   * Starts serving. Returns 1 on success, 0 after an error that says what to change.
   */
  int Start();
  void Stop();
  bool IsRunning() const;
  /** The URL to open (token included); empty before Start(). */
  const char* GetUrl();
  const char* GetAccessToken();
  /** The port actually bound (Port may be 0: any free port). */
  int GetBoundPort() const;

  /**
   * One step of the render loop: applies the viewer's interaction, takes the newest pose
   * and, when something changed or the view is still converging, renders, denoises,
   * encodes and publishes a frame. Otherwise waits up to waitSeconds for a pose, an
   * interaction or a client. Returns 1 when a frame was published, 0 when not, -1 on error.
   */
  int ProcessFrame(double waitSeconds = 0.05);

  /**
   * Runs ProcessFrame() until durationSeconds pass (<= 0: no limit), maximumFrames frames
   * are published (<= 0: no limit) or RequestStop() is called (from any thread).
   * Returns the number of frames published, -1 on error.
   */
  int Run(double durationSeconds = 0.0, int maximumFrames = 0);
  void RequestStop();

  ///@{
  /** The last published frame's id, pose id and times in milliseconds. */
  vtkGetMacro(FrameId, vtkTypeUInt64);
  vtkGetMacro(LastPoseId, vtkTypeUInt64);
  vtkGetMacro(LastRenderTime, double);
  vtkGetMacro(LastDenoiseTime, double);
  vtkGetMacro(LastEncodeTime, double);
  /** Encoded bytes of the last frame (both eyes, per codec). */
  vtkGetMacro(LastJpegBytes, vtkTypeUInt64);
  vtkGetMacro(LastH264Bytes, vtkTypeUInt64);
  ///@}

  ///@{
  /** Server counters (see hv::remoting::ServerCounters). */
  int GetNumberOfClients();
  vtkTypeUInt64 GetNumberOfPosesReceived();
  vtkTypeUInt64 GetNumberOfRejectedMessages();
  vtkTypeUInt64 GetNumberOfDroppedFrames();
  /** The controller's latest pose-to-display report, milliseconds (0 before one). */
  double GetPoseToDisplayTime();
  ///@}

  /**
   * The volume's placement (data to world, world units) now; identity before Start().
   */
  void GetVolumePlacement(vtkMatrix4x4* placement);

  /**
   * The controller's newest head pose (head to world, world units: translation in metres
   * times WorldUnitsPerMetre; the head looks along its -Z with +Y up). Returns false, and
   * leaves the matrix alone, while no controller has sent a pose.
   */
  bool GetHeadPose(vtkMatrix4x4* worldFromHead);

protected:
  vtkHoloLensRemotingOutput();
  ~vtkHoloLensRemotingOutput() override;

  vtkVolume* Volume = nullptr;
  vtkStereoSpatioTemporalDenoiser* Denoiser = nullptr;
  double InitialVolumeCenter[3] = { 0.0, 1.3, -0.7 };
  double WorldUnitsPerMetre = 1000.0;
  int VolumeOrientation = ORIENTATION_RAS;
  int EyeSize[2] = { 1440, 936 };
  int MaximumStillFrames = 32;
  char* BindAddress = nullptr;
  int Port = 8080;
  bool AllowRemoteConnections = false;
  char* AccessToken = nullptr;
  char* CertificateFile = nullptr;
  char* PrivateKeyFile = nullptr;
  char* WebRoot = nullptr;
  int Codec = CODEC_JPEG;
  int JpegQuality = 85;
  int H264BitRate = 20000000;
  int MaximumFramesInFlight = 2;
  int MaximumMessageSize = 65536;
  bool LogConnections = true;
  vtkTypeUInt64 FrameId = 0;
  vtkTypeUInt64 LastPoseId = 0;
  double LastRenderTime = 0.0;
  double LastDenoiseTime = 0.0;
  double LastEncodeTime = 0.0;
  vtkTypeUInt64 LastJpegBytes = 0;
  vtkTypeUInt64 LastH264Bytes = 0;

private:
  vtkHoloLensRemotingOutput(const vtkHoloLensRemotingOutput&) = delete;
  void operator=(const vtkHoloLensRemotingOutput&) = delete;

  struct Internals;
  std::unique_ptr<Internals> Internal;
};

#endif
