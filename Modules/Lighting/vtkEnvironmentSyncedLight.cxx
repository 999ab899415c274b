// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "vtkEnvironmentSyncedLight.h"

#include "hv/lighting/EnvironmentSynchronizer.h"

#include "vtkCellArray.h"
#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkMatrix4x4.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkStringArray.h"

#include <opencv2/imgproc.hpp>

#include <exception>
#include <string>

vtkStandardNewMacro(vtkEnvironmentSyncedLight);

struct vtkEnvironmentSyncedLight::Internals
{
  hv::lighting::EnvironmentSynchronizer Synchronizer;
  // Identity of the last distinct input frame: the input's modification time, and its
  // "FrameIndex" when the source provides one.
  vtkMTimeType LastInputTime = 0;
  double LastFrameIndex = -1.0;
  // Distinct input frames seen, the output's "FrameIndex" for sources that give none: the
  // denoiser counts T once per index, and without it would count only the first frame's.
  // Never reset, so that an index is not given twice.
  double DistinctFrames = -1.0;
  std::string LoadedResponseFile;
  cv::Mat Panorama;
  // Warn once when the volume leaves the proxy room, not on every frame it stays outside.
  bool ProxyWasAdjusted = false;
};

vtkEnvironmentSyncedLight::vtkEnvironmentSyncedLight()
  : HeadsetPose(vtkMatrix4x4::New())
  , CameraMountTransform(vtkMatrix4x4::New())
  , Internal(new Internals)
{
  this->SetNumberOfInputPorts(1);
  this->SetNumberOfOutputPorts(2);
}

vtkEnvironmentSyncedLight::~vtkEnvironmentSyncedLight()
{
  this->HeadsetPose->Delete();
  this->CameraMountTransform->Delete();
  this->SetCameraResponseFileName(nullptr);
}

void vtkEnvironmentSyncedLight::SetHeadsetPose(vtkMatrix4x4* worldFromHeadset)
{
  if (!worldFromHeadset)
  {
    vtkErrorMacro("SetHeadsetPose needs a matrix (world from headset); pass identity for none.");
    return;
  }
  for (int i = 0; i < 16; ++i)
  {
    if (this->HeadsetPose->GetData()[i] != worldFromHeadset->GetData()[i])
    {
      this->HeadsetPose->DeepCopy(worldFromHeadset);
      this->Modified();
      return;
    }
  }
}

void vtkEnvironmentSyncedLight::SetCameraMountTransform(vtkMatrix4x4* headsetFromCamera)
{
  if (!headsetFromCamera)
  {
    vtkErrorMacro(
      "SetCameraMountTransform needs a matrix (headset from camera); pass identity for none.");
    return;
  }
  for (int i = 0; i < 16; ++i)
  {
    if (this->CameraMountTransform->GetData()[i] != headsetFromCamera->GetData()[i])
    {
      this->CameraMountTransform->DeepCopy(headsetFromCamera);
      this->Modified();
      return;
    }
  }
}

void vtkEnvironmentSyncedLight::ResetHistory()
{
  this->Internal->Synchronizer.reset();
  this->Internal->LastInputTime = 0;
  this->Internal->LastFrameIndex = -1.0;
  this->Modified();
}

vtkPolyData* vtkEnvironmentSyncedLight::GetDetectedLights()
{
  return vtkPolyData::SafeDownCast(this->GetOutputDataObject(1));
}

int vtkEnvironmentSyncedLight::FillOutputPortInformation(int port, vtkInformation* info)
{
  if (port == 1)
  {
    info->Set(vtkDataObject::DATA_TYPE_NAME(), "vtkPolyData");
    return 1;
  }
  return this->Superclass::FillOutputPortInformation(port, info);
}

int vtkEnvironmentSyncedLight::RequestInformation(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  int inputExtent[6];
  inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), inputExtent);
  const int inputHeight = inputExtent[3] - inputExtent[2] + 1;
  const int height = this->OutputHeight > 0 ? this->OutputHeight : inputHeight;
  int extent[6] = { 0, 2 * height - 1, 0, height - 1, 0, 0 };
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent, 6);
  double spacing[3] = { 1.0, 1.0, 1.0 };
  double origin[3] = { 0.0, 0.0, 0.0 };
  outInfo->Set(vtkDataObject::SPACING(), spacing, 3);
  outInfo->Set(vtkDataObject::ORIGIN(), origin, 3);
  vtkDataObject::SetPointDataActiveScalarInfo(outInfo, VTK_FLOAT, 3);
  return 1;
}

int vtkEnvironmentSyncedLight::RequestUpdateExtent(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector*)
{
  // The whole panorama is needed whatever piece of Q is asked for.
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  int wholeExtent[6];
  inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), wholeExtent);
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), wholeExtent, 6);
  return 1;
}

namespace
{
std::string FieldString(vtkDataObject* data, const char* name)
{
  vtkFieldData* fieldData = data->GetFieldData();
  if (auto* strings =
        vtkStringArray::SafeDownCast(fieldData ? fieldData->GetAbstractArray(name) : nullptr))
  {
    return strings->GetNumberOfValues() > 0 ? strings->GetValue(0) : std::string();
  }
  return std::string();
}

glm::mat4 ToGlm(vtkMatrix4x4* matrix)
{
  // vtkMatrix4x4 is row-major, glm column-major.
  glm::mat4 m;
  for (int row = 0; row < 4; ++row)
  {
    for (int column = 0; column < 4; ++column)
    {
      m[column][row] = static_cast<float>(matrix->GetElement(row, column));
    }
  }
  return m;
}

void AddScalarField(vtkFieldData* fieldData, const char* name, double value)
{
  vtkNew<vtkDoubleArray> array;
  array->SetName(name);
  array->InsertNextValue(value);
  fieldData->AddArray(array);
}
}

int vtkEnvironmentSyncedLight::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkImageData* input = vtkImageData::GetData(inputVector[0]);
  vtkImageData* output = vtkImageData::GetData(outputVector, 0);
  vtkPolyData* lightsOutput = vtkPolyData::GetData(outputVector, 1);
  if (!input || !output || !lightsOutput)
  {
    vtkErrorMacro("Connect a camera-frame panorama (vtkImageData) to input port 0.");
    return 0;
  }
  int dimensions[3];
  input->GetDimensions(dimensions);
  vtkDataArray* scalars = input->GetPointData()->GetScalars();
  if (!scalars)
  {
    vtkErrorMacro("The input panorama has no point scalars; pass an RGB image (for example "
                  "the output of vtkDualFisheyeToEquirectangular).");
    return 0;
  }
  if (dimensions[2] != 1 || dimensions[0] != 2 * dimensions[1])
  {
    vtkErrorMacro("The input is " << dimensions[0] << " x " << dimensions[1] << " x "
                                  << dimensions[2]
                                  << "; an equirectangular panorama is one slice with width = 2 x "
                                     "height. Stitch dual-fisheye frames first "
                                     "(vtkDualFisheyeToEquirectangular).");
    return 0;
  }
  const int components = scalars->GetNumberOfComponents();
  const int dataType = scalars->GetDataType();
  int depth;
  switch (dataType)
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
    default:
      vtkErrorMacro("Panorama scalars of type " << scalars->GetDataTypeAsString()
                                                << " are not supported: use unsigned char or "
                                                   "unsigned short (display-referred) or float "
                                                   "(linear), e.g. with vtkImageCast.");
      return 0;
  }
  if (components != 1 && components != 3 && components != 4)
  {
    vtkErrorMacro("The panorama has " << components
                                      << " components; expected RGB (3), RGBA (4, alpha is "
                                         "ignored) or grey (1, used for all three channels).");
    return 0;
  }

  // VTK's rows run from the bottom (nadir) up; the kernels' from the zenith down.
  const cv::Mat wrapped(
    dimensions[1], dimensions[0], CV_MAKETYPE(depth, components), scalars->GetVoidPointer(0));
  cv::Mat& panorama = this->Internal->Panorama;
  if (components == 3)
  {
    cv::flip(wrapped, panorama, 0);
  }
  else
  {
    cv::Mat flipped;
    cv::flip(wrapped, flipped, 0);
    cv::cvtColor(flipped, panorama, components == 1 ? cv::COLOR_GRAY2RGB : cv::COLOR_RGBA2RGB);
  }
  if (depth == CV_32F && !cv::checkRange(panorama))
  {
    vtkErrorMacro("The input panorama holds NaN or infinite values; repair it at the source "
                  "(vtkEnvironmentMapReader::ReplaceNonFiniteValuesOn for files).");
    return 0;
  }

  bool highDynamicRange = false;
  if (this->InputDynamicRange == HIGH_DYNAMIC_RANGE)
  {
    if (depth != CV_32F)
    {
      vtkErrorMacro("InputDynamicRange is HIGH_DYNAMIC_RANGE but the panorama has integer "
                    "values: pass float radiance or set AUTOMATIC_DYNAMIC_RANGE.");
      return 0;
    }
    highDynamicRange = true;
  }
  else if (this->InputDynamicRange == AUTOMATIC_DYNAMIC_RANGE && depth == CV_32F)
  {
    std::string encoding = FieldString(input, "SourceEncoding");
    if (encoding.empty())
    {
      encoding = FieldString(input, "Encoding");
    }
    // A float panorama without a word about its origin is taken as scene-linear HDR, as an
    // EXR read by vtkEnvironmentMapReader is.
    highDynamicRange = encoding != "DisplayReferred";
  }

  hv::lighting::EnvironmentSynchronizer& synchronizer = this->Internal->Synchronizer;
  try
  {
    const std::string responseFile =
      this->CameraResponseFileName ? this->CameraResponseFileName : "";
    if (responseFile != this->Internal->LoadedResponseFile)
    {
      if (responseFile.empty())
      {
        synchronizer.cameraResponse().setSRGB();
      }
      else
      {
        synchronizer.cameraResponse() = hv::lighting::CameraResponse::load(responseFile);
      }
      this->Internal->LoadedResponseFile = responseFile;
    }

    hv::lighting::PanoramaAlignment& alignment = synchronizer.alignment();
    alignment.setCameraMount(ToGlm(this->CameraMountTransform));
    if (this->ProxyGeometry == WORLD_BOX)
    {
      alignment.setProxyBox(glm::vec3(this->ProxyBox[0], this->ProxyBox[2], this->ProxyBox[4]),
        glm::vec3(this->ProxyBox[1], this->ProxyBox[3], this->ProxyBox[5]));
    }
    else
    {
      alignment.setProxySphere(static_cast<float>(this->ProxyRadius));
    }
    const auto& status = alignment.update(ToGlm(this->HeadsetPose),
      glm::vec3(this->VolumeCenter[0], this->VolumeCenter[1], this->VolumeCenter[2]));
    if (status.ProxyAdjusted && !this->Internal->ProxyWasAdjusted)
    {
      vtkWarningMacro("The volume centre lies outside the proxy room; the room was enlarged to "
        << status.EffectiveRadius << " (sphere) or the centre clamped into it (box). Set "
        << "ProxyRadius or ProxyBox to the real room's size.");
    }
    this->Internal->ProxyWasAdjusted = status.ProxyAdjusted;

    hv::lighting::LightSourceEstimator::Parameters estimation =
      synchronizer.estimator().parameters();
    estimation.Operator = this->RadianceRecovery == LDR_AS_HDR
      ? hv::lighting::ExpansionOperator::None
      : (this->RadianceRecovery == LANDIS_EXPANSION
            ? hv::lighting::ExpansionOperator::Landis
            : hv::lighting::ExpansionOperator::LightSourceModel);
    synchronizer.estimator().setParameters(estimation);

    hv::lighting::IlluminationDifference::Parameters difference =
      synchronizer.illuminationDifference().parameters();
    if (difference.PatchGrid != this->PatchGridSize)
    {
      // Similarities of another grid are not comparable: start the sequence afresh.
      synchronizer.reset();
    }
    difference.PatchGrid = this->PatchGridSize;
    difference.Mode = this->IlluminationDifferenceMode == MOST_SIMILAR_PATCH
      ? hv::lighting::IlluminationDifferenceMode::MostSimilarPatch
      : hv::lighting::IlluminationDifferenceMode::LeastSimilarPatch;
    synchronizer.illuminationDifference().setParameters(difference);

    hv::lighting::RadianceTemporalFilter::Parameters smoothing =
      synchronizer.temporalFilter().parameters();
    smoothing.MinBlend = static_cast<float>(this->TemporalSmoothingWeight);
    smoothing.LowThreshold = static_cast<float>(this->TemporalSmoothingLowT);
    smoothing.HighThreshold = static_cast<float>(this->TemporalSmoothingHighT);
    synchronizer.temporalFilter().setParameters(smoothing);
    synchronizer.setTemporalSmoothing(this->TemporalSmoothing);
    synchronizer.setExposure(static_cast<float>(this->Exposure));
    synchronizer.setOutputHeight(this->OutputHeight);
  }
  catch (const std::exception& error)
  {
    vtkErrorMacro(<< error.what());
    return 0;
  }

  // A new camera frame, or the same frame again for a new pose or setting.
  double frameIndex = -1.0;
  vtkDataArray* sourceIndex =
    input->GetFieldData() ? input->GetFieldData()->GetArray("FrameIndex") : nullptr;
  if (sourceIndex)
  {
    frameIndex = sourceIndex->GetNumberOfTuples() > 0 ? sourceIndex->GetComponent(0, 0) : -1.0;
  }
  const bool newFrame = input->GetMTime() != this->Internal->LastInputTime ||
    frameIndex != this->Internal->LastFrameIndex;
  if (newFrame)
  {
    this->Internal->DistinctFrames += 1.0;
  }

  const hv::lighting::EnvironmentSynchronizer::Result* result = nullptr;
  try
  {
    result = &synchronizer.process(panorama,
      highDynamicRange ? hv::lighting::PanoramaDynamicRange::High
                       : hv::lighting::PanoramaDynamicRange::Low,
      newFrame);
  }
  catch (const std::exception& error)
  {
    vtkErrorMacro(<< error.what());
    return 0;
  }
  this->Internal->LastInputTime = input->GetMTime();
  this->Internal->LastFrameIndex = frameIndex;
  this->IlluminationDifference = result->IlluminationDifference;
  this->LastFrameMilliseconds = result->totalMilliseconds();

  const cv::Mat& radiance = result->Radiance;
  output->SetExtent(0, radiance.cols - 1, 0, radiance.rows - 1, 0, 0);
  vtkNew<vtkFloatArray> radianceArray;
  radianceArray->SetName("Radiance");
  radianceArray->SetNumberOfComponents(3);
  radianceArray->SetNumberOfTuples(static_cast<vtkIdType>(radiance.cols) * radiance.rows);
  cv::Mat outputView(radiance.rows, radiance.cols, CV_32FC3, radianceArray->GetPointer(0));
  cv::flip(radiance, outputView, 0);
  output->GetPointData()->SetScalars(radianceArray);

  vtkFieldData* fieldData = output->GetFieldData();
  fieldData->Initialize();
  AddScalarField(fieldData, "IlluminationDifference", result->IlluminationDifference);
  AddScalarField(fieldData, "TemporalBlendWeight", result->TemporalBlendWeight);
  AddScalarField(
    fieldData, "FrameIndex", sourceIndex ? frameIndex : this->Internal->DistinctFrames);
  vtkNew<vtkFloatArray> similarity;
  similarity->SetName("PatchSimilarity");
  if (!result->PatchSimilarity.empty())
  {
    similarity->SetNumberOfComponents(result->PatchSimilarity.cols);
    similarity->SetNumberOfTuples(result->PatchSimilarity.rows);
    for (int row = 0; row < result->PatchSimilarity.rows; ++row)
    {
      for (int column = 0; column < result->PatchSimilarity.cols; ++column)
      {
        similarity->SetTypedComponent(row, column, result->PatchSimilarity.at<float>(row, column));
      }
    }
  }
  fieldData->AddArray(similarity);

  // The detected lights, as points around the volume centre.
  vtkNew<vtkPoints> points;
  vtkNew<vtkCellArray> vertices;
  vtkNew<vtkFloatArray> directions, solidAngles, colors, intensities, lightRadiance;
  directions->SetName("Direction");
  directions->SetNumberOfComponents(3);
  solidAngles->SetName("SolidAngle");
  colors->SetName("Color");
  colors->SetNumberOfComponents(3);
  intensities->SetName("Intensity");
  lightRadiance->SetName("Radiance");
  lightRadiance->SetNumberOfComponents(3);
  for (const hv::lighting::DetectedLight& light : result->Lights)
  {
    const vtkIdType id = points->InsertNextPoint(this->VolumeCenter[0] + light.Direction.x,
      this->VolumeCenter[1] + light.Direction.y, this->VolumeCenter[2] + light.Direction.z);
    vertices->InsertNextCell(1, &id);
    directions->InsertNextTuple3(light.Direction.x, light.Direction.y, light.Direction.z);
    solidAngles->InsertNextValue(light.SolidAngle);
    colors->InsertNextTuple3(light.Colour.x, light.Colour.y, light.Colour.z);
    intensities->InsertNextValue(light.Intensity);
    lightRadiance->InsertNextTuple3(light.Radiance.x, light.Radiance.y, light.Radiance.z);
  }
  lightsOutput->Initialize();
  lightsOutput->SetPoints(points);
  lightsOutput->SetVerts(vertices);
  lightsOutput->GetPointData()->AddArray(directions);
  lightsOutput->GetPointData()->AddArray(solidAngles);
  lightsOutput->GetPointData()->AddArray(colors);
  lightsOutput->GetPointData()->AddArray(intensities);
  lightsOutput->GetPointData()->AddArray(lightRadiance);
  return 1;
}

void vtkEnvironmentSyncedLight::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "HeadsetPose:\n";
  this->HeadsetPose->PrintSelf(os, indent.GetNextIndent());
  os << indent << "CameraMountTransform:\n";
  this->CameraMountTransform->PrintSelf(os, indent.GetNextIndent());
  os << indent << "VolumeCenter: (" << this->VolumeCenter[0] << ", " << this->VolumeCenter[1]
     << ", " << this->VolumeCenter[2] << ")\n";
  os << indent << "ProxyGeometry: "
     << (this->ProxyGeometry == WORLD_BOX ? "WorldBox" : "CameraCenteredSphere") << "\n";
  os << indent << "ProxyRadius: " << this->ProxyRadius << "\n";
  os << indent << "ProxyBox: (" << this->ProxyBox[0] << ", " << this->ProxyBox[1] << ", "
     << this->ProxyBox[2] << ", " << this->ProxyBox[3] << ", " << this->ProxyBox[4] << ", "
     << this->ProxyBox[5] << ")\n";
  os << indent << "OutputHeight: " << this->OutputHeight << "\n";
  os << indent << "InputDynamicRange: " << this->InputDynamicRange << "\n";
  os << indent << "RadianceRecovery: " << this->RadianceRecovery << "\n";
  os << indent << "Exposure: " << this->Exposure << "\n";
  os << indent << "CameraResponseFileName: "
     << (this->CameraResponseFileName ? this->CameraResponseFileName : "(sRGB)") << "\n";
  os << indent << "PatchGridSize: " << this->PatchGridSize << "\n";
  os << indent << "IlluminationDifferenceMode: "
     << (this->IlluminationDifferenceMode == MOST_SIMILAR_PATCH ? "MostSimilarPatch"
                                                                : "LeastSimilarPatch")
     << "\n";
  os << indent << "TemporalSmoothing: " << this->TemporalSmoothing << "\n";
  os << indent << "TemporalSmoothingWeight: " << this->TemporalSmoothingWeight << "\n";
  os << indent << "TemporalSmoothingLowT: " << this->TemporalSmoothingLowT << "\n";
  os << indent << "TemporalSmoothingHighT: " << this->TemporalSmoothingHighT << "\n";
  os << indent << "IlluminationDifference: " << this->IlluminationDifference << "\n";
  os << indent << "LastFrameMilliseconds: " << this->LastFrameMilliseconds << "\n";
}
