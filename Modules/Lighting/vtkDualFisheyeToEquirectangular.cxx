// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "vtkDualFisheyeToEquirectangular.h"

#include "vtkDataArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkStringArray.h"

#include "hv/lighting/DualFisheyeStitcher.h"

#include <opencv2/imgproc.hpp>

#include <cfloat>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

vtkStandardNewMacro(vtkDualFisheyeToEquirectangular);

struct vtkDualFisheyeToEquirectangular::vtkInternals
{
  hv::lighting::FisheyeCalibration Calibration;
  bool HasCalibration = false;
  // The settings the calibration was loaded with: SetInputData() and the like also modify
  // the filter, so its MTime alone would reload and rebuild for every new frame.
  std::string CalibrationSettings;
  bool ReloadRequested = false;
  bool CalibrationChanged = false;
  hv::lighting::DualFisheyeStitcher Stitcher;
  cv::Mat Converted;
  cv::Mat Rgb;
  cv::Mat Reduced;
  cv::Mat Linear;
  cv::Mat ClippedChannels; // CV_8UC1, 3 values per pixel
  cv::Mat Clipped;         // the same memory as CV_8UC3
  cv::Mat PanoramaClipped;
};

namespace
{
const std::vector<std::string>& PresetNames()
{
  static const std::vector<std::string> names = hv::lighting::calibrationPresetNames();
  return names;
}

std::string PresetList()
{
  std::string list;
  for (const std::string& name : PresetNames())
  {
    list += (list.empty() ? "\"" : ", \"") + name + "\"";
  }
  return list;
}

// The sRGB EOTF (IEC 61966-2-1): encoded value in [0, 1] -> linear.
float SrgbToLinear(double encoded)
{
  return static_cast<float>(
    encoded <= 0.04045 ? encoded / 12.92 : std::pow((encoded + 0.055) / 1.055, 2.4));
}

// The sRGB EOTF of the 256 8-bit codes, as a camera response table.
const cv::Mat& SrgbResponse8()
{
  static const cv::Mat table = []
  {
    cv::Mat lut(1, 256, CV_32FC1);
    for (int i = 0; i < 256; ++i)
    {
      lut.at<float>(i) = SrgbToLinear(i / 255.0);
    }
    return lut;
  }();
  return table;
}

// Display-referred RGB of any supported depth -> linear CV_32FC3 (1 = full scale).
void Linearize(const cv::Mat& encoded, cv::Mat& linear)
{
  switch (encoded.depth())
  {
    case CV_8U:
      cv::LUT(encoded, SrgbResponse8(), linear);
      return;
    case CV_16U:
    {
      // cv::LUT only takes 8-bit input: a 65536-entry table by hand.
      static const std::vector<float> table = []
      {
        std::vector<float> values(65536);
        for (int i = 0; i < 65536; ++i)
        {
          values[i] = SrgbToLinear(i / 65535.0);
        }
        return values;
      }();
      linear.create(encoded.size(), CV_32FC3);
      for (int y = 0; y < encoded.rows; ++y)
      {
        const unsigned short* source = encoded.ptr<unsigned short>(y);
        float* target = linear.ptr<float>(y);
        for (int i = 0; i < 3 * encoded.cols; ++i)
        {
          target[i] = table[source[i]];
        }
      }
      return;
    }
    default:
    {
      // Display-referred float in [0, 1]: OpenCV has no sRGB-to-linear conversion.
      encoded.convertTo(linear, CV_32F);
      for (int y = 0; y < linear.rows; ++y)
      {
        float* row = linear.ptr<float>(y);
        for (int i = 0; i < 3 * linear.cols; ++i)
        {
          row[i] = SrgbToLinear(std::min(std::max(row[i], 0.0f), 1.0f));
        }
      }
    }
  }
}

double FullScale(int depth)
{
  return depth == CV_8U ? 255.0 : (depth == CV_16U ? 65535.0 : 1.0);
}
}

vtkDualFisheyeToEquirectangular::vtkDualFisheyeToEquirectangular()
  : Internals(new vtkInternals)
{
  this->SetNumberOfInputPorts(1);
  this->SetNumberOfOutputPorts(1);
}

vtkDualFisheyeToEquirectangular::~vtkDualFisheyeToEquirectangular()
{
  this->SetCalibrationFileName(nullptr);
  this->SetPreset(nullptr);
}

void vtkDualFisheyeToEquirectangular::ReloadCalibration()
{
  this->Internals->ReloadRequested = true;
  this->Modified();
}

int vtkDualFisheyeToEquirectangular::GetNumberOfPresets()
{
  return static_cast<int>(PresetNames().size());
}

const char* vtkDualFisheyeToEquirectangular::GetPresetName(int index)
{
  if (index < 0 || index >= GetNumberOfPresets())
  {
    return nullptr;
  }
  return PresetNames()[static_cast<std::size_t>(index)].c_str();
}

int vtkDualFisheyeToEquirectangular::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

int vtkDualFisheyeToEquirectangular::RequestInformation(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  const int width = this->OutputDimensions[0];
  const int height = this->OutputDimensions[1];
  if (height < 2 || width != 2 * height)
  {
    vtkErrorMacro("OutputDimensions are " << width << "x" << height
                                          << "; an equirectangular panorama must be twice as "
                                             "wide as high: use SetOutputDimensions(512, 256).");
    return 0;
  }
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  int extent[6] = { 0, width - 1, 0, height - 1, 0, 0 };
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent, 6);
  double spacing[3] = { 1.0, 1.0, 1.0 };
  double origin[3] = { 0.0, 0.0, 0.0 };
  outInfo->Set(vtkDataObject::SPACING(), spacing, 3);
  outInfo->Set(vtkDataObject::ORIGIN(), origin, 3);
  vtkDataObject::SetPointDataActiveScalarInfo(outInfo, VTK_FLOAT, 3);
  return 1;
}

int vtkDualFisheyeToEquirectangular::RequestUpdateExtent(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector*)
{
  // The panorama needs the whole frame whatever piece of it is requested.
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  if (inInfo && inInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
  {
    inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(),
      inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()), 6);
  }
  return 1;
}

int vtkDualFisheyeToEquirectangular::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkImageData* input = vtkImageData::GetData(inputVector[0]);
  vtkImageData* output = vtkImageData::GetData(outputVector);
  output->Initialize(); // an error leaves the output empty
  vtkInternals& internals = *this->Internals;

  // ---- the input frame ----
  vtkDataArray* scalars = input ? input->GetPointData()->GetScalars() : nullptr;
  if (!scalars && input)
  {
    scalars = input->GetPointData()->GetArray("Frame");
  }
  if (!scalars)
  {
    vtkErrorMacro("The input has no point scalars: connect a dual-fisheye frame (for example "
                  "vtkPanoramaVideoSource's output).");
    return 0;
  }
  int dims[3];
  input->GetDimensions(dims);
  if (dims[2] != 1 || dims[0] < 2 || dims[1] < 2)
  {
    vtkErrorMacro("The input is " << dims[0] << "x" << dims[1] << "x" << dims[2]
                                  << "; a dual-fisheye frame is a 2D image.");
    return 0;
  }
  if (scalars->GetNumberOfTuples() != static_cast<vtkIdType>(dims[0]) * dims[1])
  {
    vtkErrorMacro("The input's scalars hold " << scalars->GetNumberOfTuples() << " tuples for "
                                              << dims[0] << "x" << dims[1]
                                              << " points; the frame is inconsistent.");
    return 0;
  }
  const int components = scalars->GetNumberOfComponents();
  const int type = scalars->GetDataType();
  int depth = -1;
  switch (type)
  {
    case VTK_UNSIGNED_CHAR:
      depth = CV_8U;
      break;
    case VTK_UNSIGNED_SHORT:
      depth = CV_16U;
      break;
    case VTK_FLOAT:
      depth = CV_32F;
      break;
    case VTK_DOUBLE:
      depth = CV_64F;
      break;
    default:
      break;
  }
  if (depth < 0 || components < 1 || components > 4)
  {
    vtkErrorMacro("Unsupported frame scalars: " << components << " component(s) of "
                                                << scalars->GetDataTypeAsString()
                                                << ". Use 1 (grey), 3 (RGB) or 4 (RGBA) "
                                                   "components of unsigned char, unsigned short, "
                                                   "float or double (vtkImageCast converts).");
    return 0;
  }
  bool displayReferred = depth == CV_8U || depth == CV_16U;
  vtkStringArray* encodingArray =
    vtkStringArray::SafeDownCast(input->GetFieldData()->GetAbstractArray("Encoding"));
  if (encodingArray && encodingArray->GetNumberOfValues() > 0)
  {
    const std::string encoding = encodingArray->GetValue(0);
    if (encoding != "SceneLinear" && encoding != "DisplayReferred")
    {
      vtkErrorMacro("The input's field data Encoding is '"
        << encoding << "'; expected \"DisplayReferred\" or \"SceneLinear\".");
      return 0;
    }
    displayReferred = encoding == "DisplayReferred";
  }

  // ---- the calibration (reloaded only when a setting changed) ----
  const std::string settings =
    std::string(this->CalibrationFileName ? this->CalibrationFileName : "") + "\n" +
    (this->Preset ? this->Preset : "") + "\n" + std::to_string(this->BlendBandDegrees) + "\n" +
    std::to_string(this->AutomaticGainMatching);
  if (!internals.HasCalibration || internals.ReloadRequested ||
    settings != internals.CalibrationSettings)
  {
    internals.HasCalibration = false;
    internals.CalibrationSettings = settings;
    internals.ReloadRequested = false;
    const bool haveFile = this->CalibrationFileName && *this->CalibrationFileName;
    const bool havePreset = this->Preset && *this->Preset;
    if (!haveFile && !havePreset)
    {
      vtkErrorMacro("No fisheye calibration: call SetPreset() with one of "
        << PresetList()
        << ", or SetCalibrationFileName() with a calibration JSON file "
           "(Documentation/FisheyeCalibration.md).");
      return 0;
    }
    try
    {
      internals.Calibration = haveFile ? hv::lighting::loadCalibration(this->CalibrationFileName)
                                       : hv::lighting::presetCalibration(this->Preset);
    }
    catch (const std::exception& error)
    {
      vtkErrorMacro("Cannot use the fisheye calibration: " << error.what());
      return 0;
    }
    if (this->BlendBandDegrees >= 0.0)
    {
      internals.Calibration.Stitching.BlendBandDegrees = std::min(this->BlendBandDegrees, 90.0);
    }
    if (this->AutomaticGainMatching >= 0)
    {
      internals.Calibration.Stitching.AutomaticGainMatching = this->AutomaticGainMatching == 1;
    }
    internals.HasCalibration = true;
    internals.CalibrationChanged = true;
  }

  // ---- the stitcher (tables rebuilt only when the calibration or a size changed) ----
  const cv::Size inputSize(dims[0], dims[1]);
  const cv::Size outputSize(this->OutputDimensions[0], this->OutputDimensions[1]);
  const int reduction = displayReferred ? this->InputReductionFactor : 1;
  if ((reduction & (reduction - 1)) != 0)
  {
    vtkErrorMacro(
      "InputReductionFactor is " << reduction << "; use a power of two (1, 2, 4, ...).");
    return 0;
  }
  const cv::Size stitchSize = hv::lighting::reducedFrameSize(inputSize, reduction);
  try
  {
    if (!internals.Stitcher.isConfigured() || internals.CalibrationChanged ||
      internals.Stitcher.frameSize() != stitchSize ||
      internals.Stitcher.outputSize() != outputSize ||
      internals.Stitcher.options().PrefilterLargeInput != this->PrefilterLargeInput ||
      !internals.Stitcher.options().FrameBottomUp)
    {
      this->UpdateProgress(0.0);
      hv::lighting::DualFisheyeStitcherOptions options;
      options.PrefilterLargeInput = this->PrefilterLargeInput;
      // VTK images are bottom row first: the tables read and write that order directly.
      options.FrameBottomUp = true;
      options.PanoramaBottomUp = true;
      internals.Stitcher.configure(internals.Calibration, stitchSize, outputSize, options);
      internals.CalibrationChanged = false;
      ++this->NumberOfTableBuilds;
      this->UpdateProgress(0.5);
    }
  }
  catch (const std::invalid_argument& error)
  {
    vtkErrorMacro("Cannot stitch this " << dims[0] << "x" << dims[1] << " frame: " << error.what());
    return 0;
  }

  // ---- frame -> RGB, linear; rows stay in VTK's order (the stitcher's tables read and
  // write bottom-up), so nothing is flipped ----
  cv::Mat wrapped(dims[1], dims[0], CV_MAKETYPE(depth, components), scalars->GetVoidPointer(0));
  if (depth == CV_32F || depth == CV_64F)
  {
    if (!cv::checkRange(wrapped, true, nullptr, -DBL_MAX, DBL_MAX))
    {
      vtkErrorMacro("The frame holds NaN or infinite values; repair the source or replace them "
                    "(e.g. vtkEnvironmentMapReader's ReplaceNonFiniteValues).");
      return 0;
    }
  }
  cv::Mat source = wrapped;
  if (depth == CV_64F)
  {
    wrapped.convertTo(internals.Converted, CV_32F);
    source = internals.Converted;
  }
  // `encoded` is a header only: it views the input array, or one of the owned buffers, so
  // that no OpenCV call ever writes into the input's memory.
  cv::Mat encoded = source;
  switch (components)
  {
    case 1:
      cv::cvtColor(source, internals.Rgb, cv::COLOR_GRAY2RGB);
      encoded = internals.Rgb;
      break;
    case 2:
    {
      cv::Mat grey;
      cv::extractChannel(source, grey, 0);
      cv::cvtColor(grey, internals.Rgb, cv::COLOR_GRAY2RGB);
      encoded = internals.Rgb;
      break;
    }
    case 4:
      cv::cvtColor(source, internals.Rgb, cv::COLOR_RGBA2RGB);
      encoded = internals.Rgb;
      break;
    default:
      break;
  }
  if (reduction > 1)
  {
    hv::lighting::reduceFrame(encoded, internals.Reduced, reduction);
    encoded = internals.Reduced;
  }
  const bool clippedMask = displayReferred && this->ComputeClippedFraction;
  if (clippedMask)
  {
    // Per channel 255 where the channel reaches the threshold; the stitcher takes the largest
    // of the three remapped coverages (cheaper than the per-pixel maximum over channels on
    // the whole frame). On a reduced frame this flags blocks that clipped as a whole, which is
    // what the HDR estimation looks for.
    // The epsilon keeps 250/255 of 255 from rounding up to code 251.
    const double threshold = this->ClippingThreshold * FullScale(encoded.depth()) - 1e-6;
    cv::compare(encoded.reshape(1), threshold, internals.ClippedChannels, cv::CMP_GE);
    internals.Clipped = internals.ClippedChannels.reshape(3);
  }
  const bool encodedPath =
    displayReferred && encoded.depth() == CV_8U && this->InterpolateEncodedFrames;
  if (encodedPath)
  {
    // DualFisheyeStitcher::stitchEncoded linearises the samples alone.
  }
  else if (displayReferred)
  {
    Linearize(encoded, internals.Linear);
  }
  else
  {
    // Scene-linear integer codes: full scale is 1, as for the display-referred ones.
    encoded.convertTo(internals.Linear, CV_32F, 1.0 / FullScale(encoded.depth()));
    // Radiance is not negative; lossy HDR compression undershoots near black.
    cv::max(internals.Linear, 0.0, internals.Linear);
  }
  this->UpdateProgress(0.7);

  // ---- stitch straight into the output arrays (VTK's row order) ----
  const int width = outputSize.width;
  const int height = outputSize.height;
  vtkNew<vtkFloatArray> radiance;
  radiance->SetName("Radiance");
  radiance->SetNumberOfComponents(3);
  radiance->SetNumberOfTuples(static_cast<vtkIdType>(width) * height);
  cv::Mat radianceView(height, width, CV_32FC3, radiance->GetPointer(0));
  try
  {
    if (encodedPath)
    {
      internals.Stitcher.stitchEncoded(encoded, SrgbResponse8(), radianceView);
    }
    else
    {
      internals.Stitcher.stitch(internals.Linear, radianceView);
    }
    if (clippedMask)
    {
      internals.Stitcher.remapMask(internals.Clipped, internals.PanoramaClipped);
    }
  }
  catch (const std::exception& error)
  {
    vtkErrorMacro("Stitching failed: " << error.what());
    return 0;
  }
  if (radianceView.data != reinterpret_cast<uchar*>(radiance->GetPointer(0)))
  {
    vtkErrorMacro("Internal error: the panorama was not written into the output array.");
    return 0;
  }
  const std::array<double, 3> gain = internals.Stitcher.backToFrontGain();
  for (int c = 0; c < 3; ++c)
  {
    this->BackToFrontGain[c] = gain[c];
  }

  output->SetExtent(0, width - 1, 0, height - 1, 0, 0);
  output->SetSpacing(1.0, 1.0, 1.0);
  output->SetOrigin(0.0, 0.0, 0.0);
  output->GetPointData()->SetScalars(radiance);
  if (clippedMask)
  {
    vtkNew<vtkFloatArray> clipped;
    clipped->SetName("ClippedFraction");
    clipped->SetNumberOfComponents(1);
    clipped->SetNumberOfTuples(static_cast<vtkIdType>(width) * height);
    cv::Mat clippedView(height, width, CV_32FC1, clipped->GetPointer(0));
    internals.PanoramaClipped.convertTo(clippedView, CV_32F, 1.0 / 255.0);
    output->GetPointData()->AddArray(clipped);
  }
  output->GetFieldData()->ShallowCopy(input->GetFieldData());
  if (!encodingArray)
  {
    vtkNew<vtkStringArray> encoding;
    encoding->SetName("Encoding");
    encoding->InsertNextValue(displayReferred ? "DisplayReferred" : "SceneLinear");
    output->GetFieldData()->AddArray(encoding);
  }
  this->UpdateProgress(1.0);
  return 1;
}

void vtkDualFisheyeToEquirectangular::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "CalibrationFileName: "
     << (this->CalibrationFileName ? this->CalibrationFileName : "(none)") << "\n";
  os << indent << "Preset: " << (this->Preset ? this->Preset : "(none)") << "\n";
  os << indent << "OutputDimensions: " << this->OutputDimensions[0] << " x "
     << this->OutputDimensions[1] << "\n";
  os << indent << "BlendBandDegrees: " << this->BlendBandDegrees << "\n";
  os << indent << "AutomaticGainMatching: " << this->AutomaticGainMatching << "\n";
  os << indent << "PrefilterLargeInput: " << (this->PrefilterLargeInput ? "On" : "Off") << "\n";
  os << indent << "InputReductionFactor: " << this->InputReductionFactor << "\n";
  os << indent << "InterpolateEncodedFrames: " << (this->InterpolateEncodedFrames ? "On" : "Off")
     << "\n";
  os << indent << "ComputeClippedFraction: " << (this->ComputeClippedFraction ? "On" : "Off")
     << "\n";
  os << indent << "ClippingThreshold: " << this->ClippingThreshold << "\n";
  os << indent << "BackToFrontGain: " << this->BackToFrontGain[0] << ", "
     << this->BackToFrontGain[1] << ", " << this->BackToFrontGain[2] << "\n";
  os << indent << "NumberOfTableBuilds: " << this->NumberOfTableBuilds << "\n";
}
