// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
/**
 * @class   vtkPanoramaVideoSource
 * @brief   Live panorama frames (video file, camera, network stream, images) as vtkImageData.
 *
 * A source algorithm over hv::lighting::PanoramaFrameGrabber. The source string names a video
 * file (H.264 and anything else OpenCV's FFmpeg backend reads), a camera ("/dev/video0" or an
 * index such as "0"), a network stream URL (rtsp://, udp://, http://, tcp://, ...), a still
 * image (PNG, JPEG, 16-bit PNG, EXR, HDR, ...) or a numbered image sequence given as a printf
 * pattern ("pano_%04d.png"). A capture thread keeps only the newest frame, so the pipeline
 * never waits on the camera: with AutoAdvance on (the default) every Update() picks up the
 * newest frame if one arrived since the last, and otherwise does not re-execute (the
 * algorithm's MTime only grows when a newer frame arrives). With AutoAdvance off, call
 * UpdateToNewestFrame() to take it.
 *
 * The output has point scalars "Frame" with 3 components in R, G, B order: unsigned char for
 * 8-bit frames, unsigned short for 16-bit PNG/TIFF, float for EXR/HDR (scene-linear
 * radiance), in VTK's row order (j = 0 is the bottom row of the picture). Its field data holds
 * FrameIndex (frames since Open()), Timestamp (seconds on the steady clock at arrival),
 * Encoding ("DisplayReferred" or "SceneLinear") and FramesDropped (frames the capture thread
 * overwrote before the pipeline took them).
 *
 * Live sources reconnect after a dropped stream with a growing delay; a network stream that
 * ends counts as dropped. Greyscale frames are replicated into R, G, B and alpha is dropped;
 * NaN/Inf in HDR files is an error unless ReplaceNonFiniteValues is on; negatives are clamped
 * to 0. An unopenable source is reported with vtkErrorMacro, saying what to check.
 */

#ifndef vtkPanoramaVideoSource_h
#define vtkPanoramaVideoSource_h

#include "holoLightingModule.h" // For export macro
#include "vtkImageAlgorithm.h"

#include <memory> // For std::unique_ptr

class HOLOLIGHTING_EXPORT vtkPanoramaVideoSource : public vtkImageAlgorithm
{
public:
  static vtkPanoramaVideoSource* New();
  vtkTypeMacro(vtkPanoramaVideoSource, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /**
   * The video file, image file, image sequence pattern, camera or stream URL. Setting another
   * source closes the open one; the next Update() (or Open()) opens the new one.
   */
  virtual void SetSource(const char* source);
  vtkGetStringMacro(Source);
  ///@}

  ///@{
  /**
   * Files: start again at the end (default off: the last frame stays the output).
   */
  vtkSetMacro(Loop, bool);
  vtkGetMacro(Loop, bool);
  vtkBooleanMacro(Loop, bool);
  ///@}

  ///@{
  /**
   * Files: deliver frames at the file's frame rate (DefaultFrameRate for image sequences and
   * videos without one). Off (default): decode as fast as possible, so frames are skipped
   * when the pipeline is slower than the decoder.
   */
  vtkSetMacro(PaceToFrameRate, bool);
  vtkGetMacro(PaceToFrameRate, bool);
  vtkBooleanMacro(PaceToFrameRate, bool);
  vtkSetClampMacro(DefaultFrameRate, double, 1e-3, VTK_DOUBLE_MAX);
  vtkGetMacro(DefaultFrameRate, double);
  ///@}

  ///@{
  /**
   * Files: hand over every frame in order (default off). The next frame is decoded only once
   * the pipeline took the last one, so none is skipped however long a frame renders; with
   * PaceToFrameRate a frame still comes no earlier than its time. For processing a recording
   * offline and for runs that must not depend on the machine's load. Cameras and streams
   * ignore it. Takes effect at the next Open().
   */
  vtkSetMacro(DeliverEveryFrame, bool);
  vtkGetMacro(DeliverEveryFrame, bool);
  vtkBooleanMacro(DeliverEveryFrame, bool);
  ///@}

  ///@{
  /**
   * Live sources: reopen after the stream drops (default on), first after
   * ReconnectInitialDelay seconds, doubling the delay after every failure up to
   * ReconnectMaxDelay; give up after MaxReconnectAttempts consecutive failures (0: never).
   */
  vtkSetMacro(Reconnect, bool);
  vtkGetMacro(Reconnect, bool);
  vtkBooleanMacro(Reconnect, bool);
  vtkSetClampMacro(ReconnectInitialDelay, double, 0.0, VTK_DOUBLE_MAX);
  vtkGetMacro(ReconnectInitialDelay, double);
  vtkSetClampMacro(ReconnectMaxDelay, double, 0.0, VTK_DOUBLE_MAX);
  vtkGetMacro(ReconnectMaxDelay, double);
  vtkSetClampMacro(MaxReconnectAttempts, int, 0, VTK_INT_MAX);
  vtkGetMacro(MaxReconnectAttempts, int);
  ///@}

  ///@{
  /**
   * FFmpeg sources: the longest an open or a read may take, in seconds; a stream that stalls
   * longer is treated as dropped.
   */
  vtkSetClampMacro(OpenTimeout, double, 1e-3, VTK_DOUBLE_MAX);
  vtkGetMacro(OpenTimeout, double);
  vtkSetClampMacro(ReadTimeout, double, 1e-3, VTK_DOUBLE_MAX);
  vtkGetMacro(ReadTimeout, double);
  ///@}

  ///@{
  /**
   * HDR files: replace NaN and infinite values by 0 (default off: they are an error).
   */
  vtkSetMacro(ReplaceNonFiniteValues, bool);
  vtkGetMacro(ReplaceNonFiniteValues, bool);
  vtkBooleanMacro(ReplaceNonFiniteValues, bool);
  ///@}

  ///@{
  /**
   * Take the newest frame at every Update() (default on). Off: the output changes only after
   * UpdateToNewestFrame() or WaitForNewFrame().
   */
  vtkSetMacro(AutoAdvance, bool);
  vtkGetMacro(AutoAdvance, bool);
  vtkBooleanMacro(AutoAdvance, bool);
  ///@}

  /**
   * Opens the source with the current settings and takes its first frame. Returns false and
   * reports an error if it cannot be opened. Update() opens the source if needed.
   */
  bool Open();
  void Close();
  bool IsOpen();

  /**
   * Takes the newest frame if it is newer than the current output's; returns whether it was.
   * Never waits for the camera.
   */
  bool UpdateToNewestFrame();

  /**
   * Waits up to timeoutSeconds for a frame newer than the current one and takes it; returns
   * false on timeout, at the end of a file, or when closed. For tools and tests.
   */
  bool WaitForNewFrame(double timeoutSeconds);

  ///@{
  /**
   * The frame the next (or last) execution outputs: its index since Open() (-1 before any),
   * its arrival time (seconds, steady clock) and encoding ("DisplayReferred"/"SceneLinear").
   */
  vtkTypeInt64 GetFrameIndex();
  double GetFrameTimestamp();
  const char* GetFrameEncoding();
  ///@}

  ///@{
  /**
   * The capture status: delivering frames, frames decoded, frames overwritten before being
   * taken, reopen attempts and successful reopens, whether no further frame will come, the
   * most recent problem ("" if none) and the kind of source ("VideoFile", "Device",
   * "NetworkStream", "ImageFile", "ImageSequence"; "" before Open()).
   */
  bool GetConnected();
  vtkTypeInt64 GetFramesReceived();
  vtkTypeInt64 GetFramesDropped();
  vtkTypeInt64 GetReconnectAttempts();
  vtkTypeInt64 GetReconnectCount();
  bool GetFinished();
  const char* GetLastErrorText();
  const char* GetSourceKind();
  ///@}

  /**
   * Includes the arrival of the current frame.
   */
  vtkMTimeType GetMTime() override;

protected:
  vtkPanoramaVideoSource();
  ~vtkPanoramaVideoSource() override;

  int ComputePipelineMTime(vtkInformation* request, vtkInformationVector** inInfoVec,
    vtkInformationVector* outInfoVec, int requestFromOutputPort, vtkMTimeType* mtime) override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  char* Source = nullptr;
  bool Loop = false;
  bool PaceToFrameRate = false;
  bool DeliverEveryFrame = false;
  double DefaultFrameRate = 30.0;
  bool Reconnect = true;
  double ReconnectInitialDelay = 0.25;
  double ReconnectMaxDelay = 4.0;
  int MaxReconnectAttempts = 0;
  double OpenTimeout = 5.0;
  double ReadTimeout = 2.0;
  bool ReplaceNonFiniteValues = false;
  bool AutoAdvance = true;

private:
  vtkPanoramaVideoSource(const vtkPanoramaVideoSource&) = delete;
  void operator=(const vtkPanoramaVideoSource&) = delete;

  // Warns once per new problem of a live source (dropped, reconnecting, given up).
  void ReportCaptureProblem();

  struct vtkInternals;
  std::unique_ptr<vtkInternals> Internals;
};

#endif
