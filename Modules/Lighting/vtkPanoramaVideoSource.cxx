// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "vtkPanoramaVideoSource.h"

#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkSmartPointer.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkStringArray.h"
#include "vtkTypeInt64Array.h"

#include "hv/lighting/PanoramaFrameGrabber.h"

#include <opencv2/core.hpp>

#include <algorithm>
#include <string>

vtkStandardNewMacro(vtkPanoramaVideoSource);

namespace
{
bool isLive(hv::lighting::PanoramaSourceKind kind)
{
  return kind == hv::lighting::PanoramaSourceKind::Device ||
    kind == hv::lighting::PanoramaSourceKind::NetworkStream;
}
}

struct vtkPanoramaVideoSource::vtkInternals
{
  hv::lighting::PanoramaFrameGrabber Grabber;
  // The newest frame taken from the grabber, and the one RequestInformation announced (kept
  // apart so that a frame arriving between the two passes cannot change the extent under
  // RequestData).
  hv::lighting::PanoramaFrame Current;
  hv::lighting::PanoramaFrame Executing;
  vtkTimeStamp FrameTime;               // when Current last changed
  vtkSmartPointer<vtkDataArray> Pixels; // the output's "Frame" array, reused when unshared
  std::string LastErrorText;
  std::string ReportedError; // the last grabber problem already warned about
};

vtkPanoramaVideoSource::vtkPanoramaVideoSource()
  : Internals(new vtkInternals)
{
  this->SetNumberOfInputPorts(0);
}

vtkPanoramaVideoSource::~vtkPanoramaVideoSource()
{
  this->Internals->Grabber.close();
  delete[] this->Source;
  this->Source = nullptr;
}

void vtkPanoramaVideoSource::SetSource(const char* source)
{
  if ((!source && !this->Source) || (source && this->Source && std::string(source) == this->Source))
  {
    return;
  }
  this->Close();
  delete[] this->Source;
  this->Source = nullptr;
  if (source)
  {
    this->Source = new char[std::char_traits<char>::length(source) + 1];
    std::copy(source, source + std::char_traits<char>::length(source) + 1, this->Source);
  }
  this->Modified();
}

bool vtkPanoramaVideoSource::Open()
{
  if (!this->Source || !*this->Source)
  {
    vtkErrorMacro("No source: call SetSource() with a video file, an image file or sequence "
                  "pattern (pano_%04d.png), a camera (/dev/video0 or 0) or a stream URL.");
    return false;
  }
  hv::lighting::PanoramaFrameGrabberOptions options;
  options.Loop = this->Loop;
  options.PaceToFrameRate = this->PaceToFrameRate;
  options.DeliverEveryFrame = this->DeliverEveryFrame;
  options.DefaultFrameRate = this->DefaultFrameRate;
  options.Reconnect = this->Reconnect;
  options.ReconnectInitialDelay = this->ReconnectInitialDelay;
  options.ReconnectMaxDelay = std::max(this->ReconnectMaxDelay, this->ReconnectInitialDelay);
  options.MaxReconnectAttempts = this->MaxReconnectAttempts;
  options.OpenTimeout = this->OpenTimeout;
  options.ReadTimeout = this->ReadTimeout;
  options.ReplaceNonFiniteValues = this->ReplaceNonFiniteValues;
  vtkInternals& internals = *this->Internals;
  internals.Grabber.setOptions(options);
  try
  {
    internals.Grabber.open(this->Source);
  }
  catch (const std::exception& e)
  {
    vtkErrorMacro(<< e.what());
    return false;
  }
  internals.Current = internals.Grabber.latest();
  internals.ReportedError.clear();
  internals.FrameTime.Modified();
  return true;
}

void vtkPanoramaVideoSource::Close()
{
  this->Internals->Grabber.close();
}

bool vtkPanoramaVideoSource::IsOpen()
{
  return this->Internals->Grabber.isOpen();
}

bool vtkPanoramaVideoSource::UpdateToNewestFrame()
{
  vtkInternals& internals = *this->Internals;
  if (!internals.Grabber.tryGetNewFrame(internals.Current, internals.Current.Index))
  {
    return false;
  }
  internals.FrameTime.Modified();
  return true;
}

bool vtkPanoramaVideoSource::WaitForNewFrame(double timeoutSeconds)
{
  vtkInternals& internals = *this->Internals;
  if (!internals.Grabber.waitForFrame(internals.Current, internals.Current.Index, timeoutSeconds))
  {
    return false;
  }
  internals.FrameTime.Modified();
  return true;
}

vtkMTimeType vtkPanoramaVideoSource::GetMTime()
{
  return std::max(this->Superclass::GetMTime(), this->Internals->FrameTime.GetMTime());
}

int vtkPanoramaVideoSource::ComputePipelineMTime(
  vtkInformation*, vtkInformationVector**, vtkInformationVector*, int, vtkMTimeType* mtime)
{
  // The pipeline asks for the MTime once per Update(): the moment to take a newer frame, if
  // any. When none arrived the MTime stays put and nothing downstream re-executes.
  if (this->AutoAdvance)
  {
    this->UpdateToNewestFrame();
  }
  this->ReportCaptureProblem();
  *mtime = this->GetMTime();
  return 1;
}

void vtkPanoramaVideoSource::ReportCaptureProblem()
{
  vtkInternals& internals = *this->Internals;
  const hv::lighting::PanoramaFrameGrabberStatus status = internals.Grabber.status();
  if (!status.Open || status.Connected || status.LastError.empty() ||
    status.LastError == internals.ReportedError)
  {
    return;
  }
  internals.ReportedError = status.LastError;
  if (isLive(internals.Grabber.sourceKind()) && status.Finished)
  {
    vtkErrorMacro(<< status.LastError << " The output keeps the last frame; call Open() to retry.");
  }
  else if (!status.Finished)
  {
    // A dropped live stream: the output keeps the last frame while the grabber reconnects.
    vtkWarningMacro(<< status.LastError);
  }
}

namespace
{
int VTKScalarType(int cvDepth)
{
  switch (cvDepth)
  {
    case CV_8U:
      return VTK_UNSIGNED_CHAR;
    case CV_16U:
      return VTK_UNSIGNED_SHORT;
    default:
      return VTK_FLOAT;
  }
}
}

int vtkPanoramaVideoSource::RequestInformation(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInternals& internals = *this->Internals;
  if (!internals.Grabber.isOpen() && !this->Open())
  {
    return 0;
  }
  if (internals.Current.Image.empty())
  {
    vtkErrorMacro("'" << this->Source << "' has delivered no frame yet: check the source.");
    return 0;
  }
  internals.Executing = internals.Current;
  const cv::Mat& image = internals.Executing.Image;
  int extent[6] = { 0, image.cols - 1, 0, image.rows - 1, 0, 0 };
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent, 6);
  vtkDataObject::SetPointDataActiveScalarInfo(outInfo, VTKScalarType(image.depth()), 3);
  return 1;
}

int vtkPanoramaVideoSource::RequestData(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInternals& internals = *this->Internals;
  const hv::lighting::PanoramaFrame& frame = internals.Executing;
  if (frame.Image.empty())
  {
    vtkErrorMacro("No frame to output: Open() the source first.");
    return 0;
  }
  const hv::lighting::PanoramaFrameGrabberStatus status = internals.Grabber.status();

  vtkImageData* output = vtkImageData::GetData(outputVector);
  output->SetExtent(0, frame.Image.cols - 1, 0, frame.Image.rows - 1, 0, 0);
  const int scalarType = VTKScalarType(frame.Image.depth());
  const vtkIdType pixelCount = static_cast<vtkIdType>(frame.Image.cols) * frame.Image.rows;
  // Reuse the previous frame's array when nobody but this source (and the output it is about
  // to overwrite) holds it: allocating and first-touching a fresh array costs more than the
  // copy for large frames. An array a downstream filter kept is never written to.
  vtkSmartPointer<vtkDataArray>& pixels = internals.Pixels;
  const int holders = output->GetPointData()->GetScalars() == pixels.GetPointer() ? 2 : 1;
  if (!pixels || pixels->GetReferenceCount() != holders || pixels->GetDataType() != scalarType ||
    pixels->GetNumberOfTuples() != pixelCount)
  {
    pixels.TakeReference(vtkDataArray::CreateDataArray(scalarType));
    pixels->SetName("Frame");
    pixels->SetNumberOfComponents(3);
    pixels->SetNumberOfTuples(pixelCount);
  }
  // The one copy per frame: the grabber's image (top row first) flipped into VTK's row order
  // (bottom row first) straight into the output array.
  cv::Mat target(frame.Image.rows, frame.Image.cols, frame.Image.type(), pixels->GetVoidPointer(0));
  cv::flip(frame.Image, target, 0);
  output->GetPointData()->SetScalars(pixels);

  vtkFieldData* fieldData = output->GetFieldData();
  vtkNew<vtkTypeInt64Array> index;
  index->SetName("FrameIndex");
  index->InsertNextValue(frame.Index);
  fieldData->AddArray(index);
  vtkNew<vtkDoubleArray> timestamp;
  timestamp->SetName("Timestamp");
  timestamp->InsertNextValue(frame.Timestamp);
  fieldData->AddArray(timestamp);
  vtkNew<vtkStringArray> encoding;
  encoding->SetName("Encoding");
  encoding->InsertNextValue(hv::lighting::toString(frame.Encoding));
  fieldData->AddArray(encoding);
  vtkNew<vtkTypeInt64Array> dropped;
  dropped->SetName("FramesDropped");
  dropped->InsertNextValue(status.FramesDropped);
  fieldData->AddArray(dropped);
  return 1;
}

vtkTypeInt64 vtkPanoramaVideoSource::GetFrameIndex()
{
  return this->Internals->Current.Index;
}

double vtkPanoramaVideoSource::GetFrameTimestamp()
{
  return this->Internals->Current.Timestamp;
}

const char* vtkPanoramaVideoSource::GetFrameEncoding()
{
  return hv::lighting::toString(this->Internals->Current.Encoding);
}

bool vtkPanoramaVideoSource::GetConnected()
{
  return this->Internals->Grabber.status().Connected;
}

vtkTypeInt64 vtkPanoramaVideoSource::GetFramesReceived()
{
  return this->Internals->Grabber.status().FramesReceived;
}

vtkTypeInt64 vtkPanoramaVideoSource::GetFramesDropped()
{
  return this->Internals->Grabber.status().FramesDropped;
}

vtkTypeInt64 vtkPanoramaVideoSource::GetReconnectAttempts()
{
  return this->Internals->Grabber.status().ReconnectAttempts;
}

vtkTypeInt64 vtkPanoramaVideoSource::GetReconnectCount()
{
  return this->Internals->Grabber.status().Reconnects;
}

bool vtkPanoramaVideoSource::GetFinished()
{
  return this->Internals->Grabber.status().Finished;
}

const char* vtkPanoramaVideoSource::GetLastErrorText()
{
  this->Internals->LastErrorText = this->Internals->Grabber.status().LastError;
  return this->Internals->LastErrorText.c_str();
}

const char* vtkPanoramaVideoSource::GetSourceKind()
{
  return this->Internals->Grabber.isOpen()
    ? hv::lighting::toString(this->Internals->Grabber.sourceKind())
    : "";
}

void vtkPanoramaVideoSource::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Source: " << (this->Source ? this->Source : "(none)") << "\n";
  os << indent << "Loop: " << (this->Loop ? "On" : "Off") << "\n";
  os << indent << "PaceToFrameRate: " << (this->PaceToFrameRate ? "On" : "Off") << "\n";
  os << indent << "DeliverEveryFrame: " << (this->DeliverEveryFrame ? "On" : "Off") << "\n";
  os << indent << "DefaultFrameRate: " << this->DefaultFrameRate << "\n";
  os << indent << "Reconnect: " << (this->Reconnect ? "On" : "Off") << "\n";
  os << indent << "ReconnectInitialDelay: " << this->ReconnectInitialDelay << "\n";
  os << indent << "ReconnectMaxDelay: " << this->ReconnectMaxDelay << "\n";
  os << indent << "MaxReconnectAttempts: " << this->MaxReconnectAttempts << "\n";
  os << indent << "OpenTimeout: " << this->OpenTimeout << "\n";
  os << indent << "ReadTimeout: " << this->ReadTimeout << "\n";
  os << indent << "ReplaceNonFiniteValues: " << (this->ReplaceNonFiniteValues ? "On" : "Off")
     << "\n";
  os << indent << "AutoAdvance: " << (this->AutoAdvance ? "On" : "Off") << "\n";
  const hv::lighting::PanoramaFrameGrabberStatus status = this->Internals->Grabber.status();
  os << indent << "Open: " << (status.Open ? "yes" : "no") << "\n";
  os << indent << "SourceKind: " << this->GetSourceKind() << "\n";
  os << indent << "Connected: " << (status.Connected ? "yes" : "no") << "\n";
  os << indent << "Finished: " << (status.Finished ? "yes" : "no") << "\n";
  os << indent << "FrameIndex: " << this->Internals->Current.Index << "\n";
  os << indent << "FramesReceived: " << status.FramesReceived << "\n";
  os << indent << "FramesDropped: " << status.FramesDropped << "\n";
  os << indent << "ReconnectAttempts: " << status.ReconnectAttempts << "\n";
  os << indent << "Reconnects: " << status.Reconnects << "\n";
  os << indent << "LastError: " << (status.LastError.empty() ? "(none)" : status.LastError) << "\n";
}
