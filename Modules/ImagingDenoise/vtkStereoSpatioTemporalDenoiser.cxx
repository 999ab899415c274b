// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "vtkStereoSpatioTemporalDenoiser.h"

#include "vtkDataArray.h"
#include "vtkDataObject.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkSMPTools.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkUnsignedCharArray.h"

#include "hv/denoise/StereoDenoiser.h"

#include <string>

vtkStandardNewMacro(vtkStereoSpatioTemporalDenoiser);

class vtkStereoSpatioTemporalDenoiser::vtkInternals
{
public:
  hv::denoise::StereoDenoiser Denoiser;
  // What the last executed frame was, to tell a new frame from a re-execution.
  vtkMTimeType InputTimes[2] = { 0, 0 };
  vtkImageData* Inputs[2] = { nullptr, nullptr };
  bool HasFrame = false;
  bool HasClassificationStamp = false;
  int ClassificationStamp = 0;
  bool HasDataStamp = false;
  int DataStamp = 0;
  bool HasIlluminationFrame = false;
  double IlluminationFrame = 0.0;
  // Without a "FrameIndex", the illumination input's identity: the data object and its
  // modification time.
  vtkDataObject* IlluminationInput = nullptr;
  vtkMTimeType IlluminationInputTime = 0;
  double LastIlluminationDifference = 0.0;
  double LastMilliseconds = 0.0;
  // Each eye's denoised image, written into the same array frame after frame while no one but
  // this filter holds it. A new array (21.6 MB an eye at 1440x936) came from fresh pages on the
  // first frames, which the kernel mapped one fault at a time as the denoiser wrote them: the
  // third frame took 93-95 ms instead of 68-82 (Documentation/Denoising.md, "Speed").
  vtkSmartPointer<vtkFloatArray> Denoised[2];
};

vtkStereoSpatioTemporalDenoiser::vtkStereoSpatioTemporalDenoiser()
  : Internals(new vtkInternals)
{
  this->SetNumberOfInputPorts(3);
  this->SetNumberOfOutputPorts(2);
  this->Internals->Denoiser.setParallelFor(
    [](std::int64_t count, const std::function<void(std::int64_t, std::int64_t)>& body)
    {
      vtkSMPTools::For(0, static_cast<vtkIdType>(count),
        [&body](vtkIdType begin, vtkIdType end) { body(begin, end); });
    });
  // ProgressEvent after each of the frame's first four stages; the pipeline's executive itself
  // reports 0 before RequestData and 1 after it.
  this->Internals->Denoiser.setProgress(
    [this](double fraction)
    {
      if (fraction > 0.0 && fraction < 1.0)
      {
        this->UpdateProgress(fraction);
      }
    });
}

vtkStereoSpatioTemporalDenoiser::~vtkStereoSpatioTemporalDenoiser() = default;

void vtkStereoSpatioTemporalDenoiser::SetLeftEyeData(vtkImageData* image)
{
  this->SetInputData(0, image);
}

void vtkStereoSpatioTemporalDenoiser::SetRightEyeData(vtkImageData* image)
{
  this->SetInputData(1, image);
}

void vtkStereoSpatioTemporalDenoiser::SetLeftEyeConnection(vtkAlgorithmOutput* output)
{
  this->SetInputConnection(0, output);
}

void vtkStereoSpatioTemporalDenoiser::SetRightEyeConnection(vtkAlgorithmOutput* output)
{
  this->SetInputConnection(1, output);
}

void vtkStereoSpatioTemporalDenoiser::SetIlluminationConnection(vtkAlgorithmOutput* output)
{
  this->SetInputConnection(2, output);
}

vtkImageData* vtkStereoSpatioTemporalDenoiser::GetEyeOutput(int eye)
{
  if (eye != 0 && eye != 1)
  {
    vtkErrorMacro("GetEyeOutput(" << eye << "): the eye must be 0 (left or mono) or 1 (right).");
    return nullptr;
  }
  return vtkImageData::SafeDownCast(this->GetOutputDataObject(eye));
}

void vtkStereoSpatioTemporalDenoiser::ResetHistory()
{
  this->Internals->Denoiser.reset();
  this->Internals->HasFrame = false;
  this->Modified();
}

double vtkStereoSpatioTemporalDenoiser::GetLastFrameMilliseconds()
{
  return this->Internals->LastMilliseconds;
}

double vtkStereoSpatioTemporalDenoiser::GetLastStageMilliseconds(int stage)
{
  if (stage < 0 || stage >= NumberOfStages)
  {
    return 0.0;
  }
  return this->Internals->Denoiser.statistics().milliseconds[stage];
}

double vtkStereoSpatioTemporalDenoiser::GetLastSurfaceFraction(int eye)
{
  if (eye < 0 || eye > 1)
  {
    return 0.0;
  }
  return this->Internals->Denoiser.statistics().surfaceFraction[eye];
}

int vtkStereoSpatioTemporalDenoiser::FillInputPortInformation(int port, vtkInformation* info)
{
  if (port == 2)
  {
    info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkDataObject");
  }
  else
  {
    info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  }
  if (port > 0)
  {
    info->Set(vtkAlgorithm::INPUT_IS_OPTIONAL(), 1);
  }
  return 1;
}

int vtkStereoSpatioTemporalDenoiser::FillOutputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkDataObject::DATA_TYPE_NAME(), "vtkImageData");
  return 1;
}

int vtkStereoSpatioTemporalDenoiser::RequestInformation(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  for (int port = 0; port < 2; ++port)
  {
    vtkInformation* inInfo = inputVector[port]->GetNumberOfInformationObjects() > 0
      ? inputVector[port]->GetInformationObject(0)
      : inputVector[0]->GetInformationObject(0);
    vtkInformation* outInfo = outputVector->GetInformationObject(port);
    if (inInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
    {
      outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(),
        inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()), 6);
    }
  }
  return 1;
}

// Each eye is needed whole (reprojection reaches anywhere in the other eye), and the
// illumination input only for its field data.
int vtkStereoSpatioTemporalDenoiser::RequestUpdateExtent(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector*)
{
  for (int port = 0; port < 3; ++port)
  {
    for (int i = 0; i < inputVector[port]->GetNumberOfInformationObjects(); ++i)
    {
      vtkInformation* inInfo = inputVector[port]->GetInformationObject(i);
      if (inInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
      {
        inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(),
          inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()), 6);
      }
      else
      {
        inInfo->Remove(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT());
      }
    }
  }
  return 1;
}

namespace
{
// The float array `name` with `components` components and one tuple per pixel, or nullptr
// after an error that names what is wrong.
const float* EyeArray(vtkStereoSpatioTemporalDenoiser* self, vtkImageData* image, const char* eye,
  const char* name, int components)
{
  vtkDataArray* array = image->GetPointData()->GetArray(name);
  if (!array)
  {
    vtkErrorWithObjectMacro(self,
      "The " << eye << " image has no \"" << name
             << "\" point array; connect the eye images of "
                "vtkPathTracedVolumeMapper::GetEyeOutput(), which carry all auxiliary buffers.");
    return nullptr;
  }
  auto* floats = vtkFloatArray::SafeDownCast(array);
  if (!floats || array->GetNumberOfComponents() != components ||
    array->GetNumberOfTuples() != image->GetNumberOfPoints())
  {
    vtkErrorWithObjectMacro(self,
      "The " << eye << " image's \"" << name << "\" array must be float with " << components
             << " component(s) per pixel; it has " << array->GetNumberOfComponents()
             << " component(s) of type " << array->GetDataTypeAsString() << " and "
             << array->GetNumberOfTuples() << " tuples for " << image->GetNumberOfPoints()
             << " pixels.");
    return nullptr;
  }
  return floats->GetPointer(0);
}

bool EyeMatrix(vtkStereoSpatioTemporalDenoiser* self, vtkImageData* image, const char* eye,
  const char* name, glm::mat4& matrix)
{
  vtkDataArray* array = image->GetFieldData()->GetArray(name);
  if (!array || array->GetNumberOfValues() != 16)
  {
    vtkErrorWithObjectMacro(self,
      "The " << eye << " image lacks the field array \"" << name
             << "\" (16 values, row-major); the mapper's eye images carry it. Images from "
                "elsewhere need the eye's OpenGL-convention view and projection matrices.");
    return false;
  }
  for (int row = 0; row < 4; ++row)
  {
    for (int column = 0; column < 4; ++column)
    {
      matrix[column][row] = static_cast<float>(array->GetComponent(4 * row + column, 0));
    }
  }
  return true;
}

bool FieldValue(vtkDataObject* object, const char* name, double& value)
{
  vtkDataArray* array =
    object && object->GetFieldData() ? object->GetFieldData()->GetArray(name) : nullptr;
  if (!array || array->GetNumberOfTuples() < 1)
  {
    return false;
  }
  value = array->GetComponent(0, 0);
  return true;
}

void SetFieldValue(vtkFieldData* fields, const char* name, double value)
{
  vtkNew<vtkDoubleArray> array;
  array->SetName(name);
  array->SetNumberOfTuples(1);
  array->SetValue(0, value);
  fields->AddArray(array);
}
}

int vtkStereoSpatioTemporalDenoiser::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkInternals& internals = *this->Internals;
  vtkImageData* inputs[2] = { vtkImageData::GetData(inputVector[0]),
    inputVector[1]->GetNumberOfInformationObjects() ? vtkImageData::GetData(inputVector[1])
                                                    : nullptr };
  const int eyeCount = inputs[1] ? 2 : 1;
  const char* names[2] = { eyeCount == 1 ? "eye" : "left eye", "right eye" };
  hv::denoise::EyeFrame frames[2];
  for (int e = 0; e < eyeCount; ++e)
  {
    vtkImageData* image = inputs[e];
    int dims[3];
    image->GetDimensions(dims);
    if (dims[0] < 1 || dims[1] < 1 || dims[2] != 1)
    {
      vtkErrorMacro("The " << names[e] << " image is " << dims[0] << "x" << dims[1] << "x"
                           << dims[2] << "; it must be a non-empty 2D image. Render a frame "
                           << "with vtkPathTracedVolumeMapper first.");
      return 0;
    }
    hv::denoise::EyeFrame& f = frames[e];
    f.width = dims[0];
    f.height = dims[1];
    f.radiance = EyeArray(this, image, names[e], "Radiance", 4);
    f.firstScatterPosition =
      f.radiance ? EyeArray(this, image, names[e], "FirstScatterPosition", 3) : nullptr;
    f.depth = f.firstScatterPosition ? EyeArray(this, image, names[e], "Depth", 1) : nullptr;
    f.albedo = f.depth ? EyeArray(this, image, names[e], "Albedo", 3) : nullptr;
    f.normal = f.albedo ? EyeArray(this, image, names[e], "Normal", 3) : nullptr;
    f.gradientMagnitude =
      f.normal ? EyeArray(this, image, names[e], "GradientMagnitude", 1) : nullptr;
    if (!f.gradientMagnitude)
    {
      return 0;
    }
    if (image->GetPointData()->GetArray("FirstScatterScalar"))
    {
      f.firstScatterScalar = EyeArray(this, image, names[e], "FirstScatterScalar", 1);
      if (!f.firstScatterScalar)
      {
        return 0;
      }
    }
    if (image->GetPointData()->GetArray("PreviousLightingRadiance"))
    {
      f.previousLightRadiance = EyeArray(this, image, names[e], "PreviousLightingRadiance", 3);
      if (!f.previousLightRadiance)
      {
        return 0;
      }
    }
    auto* valid = vtkUnsignedCharArray::SafeDownCast(
      image->GetPointData()->GetArray("FirstScatterValid"));
    if (!valid || valid->GetNumberOfTuples() != image->GetNumberOfPoints())
    {
      vtkErrorMacro("The " << names[e]
                           << " image has no unsigned char \"FirstScatterValid\" array with "
                              "one value per pixel; connect the mapper's eye images.");
      return 0;
    }
    f.firstScatterValid = valid->GetPointer(0);
    if (!EyeMatrix(this, image, names[e], "ViewMatrix", f.view) ||
      !EyeMatrix(this, image, names[e], "ProjectionMatrix", f.projection))
    {
      return 0;
    }
    if (image->GetFieldData()->GetArray("VolumeMatrix") &&
      !EyeMatrix(this, image, names[e], "VolumeMatrix", f.volumeMatrix))
    {
      return 0;
    }
  }

  // The transfer function or the data changed: the history shows another volume. New data
  // always drops it; a new transfer function alone may relight it instead. Images without a
  // "DataStamp" cannot tell the two apart, and drop it.
  double stamp, dataStamp;
  const bool hasDataStamp = FieldValue(inputs[0], "DataStamp", dataStamp);
  if (FieldValue(inputs[0], "ClassificationStamp", stamp))
  {
    if (internals.HasClassificationStamp && static_cast<int>(stamp) != internals.ClassificationStamp)
    {
      const bool sameData = hasDataStamp && internals.HasDataStamp &&
        static_cast<int>(dataStamp) == internals.DataStamp;
      if (sameData && this->RelightHistoryOnTransferFunctionChange)
      {
        internals.Denoiser.relightHistoryForNewClassification();
      }
      else
      {
        internals.Denoiser.reset();
        internals.HasFrame = false;
      }
    }
    internals.HasClassificationStamp = true;
    internals.ClassificationStamp = static_cast<int>(stamp);
  }
  internals.HasDataStamp = hasDataStamp;
  internals.DataStamp = hasDataStamp ? static_cast<int>(dataStamp) : 0;

  // The same input images as last time: a parameter changed, the frame is denoised again.
  bool sameFrame = internals.HasFrame;
  for (int e = 0; e < 2; ++e)
  {
    const vtkMTimeType time = inputs[e] ? inputs[e]->GetMTime() : 0;
    sameFrame = sameFrame && inputs[e] == internals.Inputs[e] && time == internals.InputTimes[e];
  }

  // T: from port 2 when connected (once per new environment frame), else the setting; a
  // re-executed frame keeps the T it had.
  double illuminationDifference = this->IlluminationDifference;
  if (sameFrame)
  {
    illuminationDifference = internals.LastIlluminationDifference;
  }
  else if (this->GetNumberOfInputConnections(2) > 0)
  {
    vtkDataObject* environment = vtkDataObject::GetData(inputVector[2]);
    if (!FieldValue(environment, "IlluminationDifference", illuminationDifference))
    {
      vtkErrorMacro("The illumination input (port 2) has no \"IlluminationDifference\" field "
                    "array; connect vtkEnvironmentSyncedLight's output, or disconnect it and "
                    "use SetIlluminationDifference().");
      return 0;
    }
    // T belongs to the lighting frame it was measured on, and counts once: an illumination
    // input that has not changed since the last frame brings no new lighting, even though its
    // field data still carries the T of its last change.
    double environmentFrame;
    if (FieldValue(environment, "FrameIndex", environmentFrame))
    {
      if (internals.HasIlluminationFrame && environmentFrame == internals.IlluminationFrame)
      {
        illuminationDifference = 0.0;
      }
      internals.HasIlluminationFrame = true;
      internals.IlluminationFrame = environmentFrame;
    }
    else
    {
      if (environment == internals.IlluminationInput &&
        environment->GetMTime() == internals.IlluminationInputTime)
      {
        illuminationDifference = 0.0;
      }
      internals.HasIlluminationFrame = false;
    }
    internals.IlluminationInput = environment;
    internals.IlluminationInputTime = environment->GetMTime();
  }

  hv::denoise::DenoiserParameters& p = internals.Denoiser.parameters();
  p.crossViewSamples = this->CrossViewSamples;
  p.temporalAccumulation = this->TemporalAccumulation;
  p.spatialFilter = this->SpatialFilter;
  p.stereoBlend = this->StereoBlend;
  p.demodulateAlbedo = this->DemodulateAlbedo;
  p.coverageAgreementWidth = static_cast<float>(this->CoverageAgreementWidth);
  p.crossViewCoverageWidth = static_cast<float>(this->CrossViewCoverageWidth);
  p.crossView.albedoSigma = static_cast<float>(this->AlbedoSigma);
  p.crossView.normalSharpness = static_cast<float>(this->NormalSharpness);
  p.crossView.depthSigma = static_cast<float>(this->DepthSigma);
  p.wavelet.albedoSigma = static_cast<float>(this->WaveletAlbedoSigma);
  p.wavelet.normalSharpness = static_cast<float>(this->WaveletNormalSharpness);
  p.wavelet.depthSigma = static_cast<float>(this->WaveletDepthSigma);
  p.wavelet.normalGradientFloor = static_cast<float>(this->WaveletNormalGradientFloor);
  p.temporal.normalGradientFloor = static_cast<float>(this->HistoryNormalGradientFloor);
  p.wavelet.albedoGradientWeight = static_cast<float>(this->WaveletAlbedoGradientWeight);
  p.sigmoidSteepness = static_cast<float>(this->SigmoidSteepness);
  p.sigmoidCentre = static_cast<float>(this->SigmoidCenter);
  p.maximumHistoryLength = this->MaximumHistoryLength;
  p.relightingRadius = static_cast<float>(this->RelightingRadius);
  p.relightingRunHeightFraction = static_cast<float>(this->RelightingRunHeightFraction);
  p.relitHistoryReuse = static_cast<float>(this->RelitHistoryReuse);
  p.relightFromPreviousLighting = this->RelightFromPreviousLighting;
  p.previousLightingRadius = static_cast<float>(this->PreviousLightingRadius);
  p.previousLightingWeight = static_cast<float>(this->PreviousLightingWeight);
  p.relitHistoryRejection = static_cast<float>(this->RelitHistoryRejection);
  p.relitHistoryRejectionHistoryVariance = this->RelitHistoryRejectionHistoryVariance;
  p.classificationScalarTolerance = static_cast<float>(this->ClassificationScalarTolerance);
  p.classificationCoverageWidth = static_cast<float>(this->ClassificationCoverageWidth);
  p.relightingRefinementFrames = this->RelightingRefinementFrames;
  p.bicubicHistory = this->BicubicHistory;
  p.maximumHistoryAngle = static_cast<float>(this->MaximumHistoryAngle);
  p.grazingHistoryCosine = static_cast<float>(this->GrazingHistoryCosine);
  p.grazingHistoryFraction = static_cast<float>(this->GrazingHistoryFraction);
  p.exponentialAverageAlpha = static_cast<float>(this->ExponentialAverageAlpha);
  p.depthTolerance = static_cast<float>(this->DepthTolerance);
  p.surfaceJitterTolerance = static_cast<float>(this->SurfaceJitterTolerance);
  p.normalTestGradient = static_cast<float>(this->NormalTestGradient);
  p.normalCosine = static_cast<float>(this->NormalTolerance);
  p.clampWidth = static_cast<float>(this->ClampWidth);
  p.waveletLevels = this->WaveletLevels;
  p.luminanceSigma = static_cast<float>(this->LuminanceSigma);
  p.waveletLongHistory = static_cast<float>(this->WaveletLongHistory);
  p.waveletDepthFromHistory = this->WaveletDepthFromHistory;
  p.remodulateByHistoryAlbedo = this->RemodulateByHistoryAlbedo;
  p.historyAlbedoGradients = glm::vec2(static_cast<float>(this->HistoryAlbedoGradients[0]),
    static_cast<float>(this->HistoryAlbedoGradients[1]));
  p.stereoAlbedoFromHistory = this->StereoAlbedoFromHistory;
  p.stereoAlpha = static_cast<float>(this->StereoAlpha);
  p.stereoBeta = static_cast<float>(this->StereoBeta);
  p.stereoAgreementWidth = static_cast<float>(this->StereoAgreementWidth);
  p.stereoCoverageWidth = static_cast<float>(this->StereoCoverageWidth);
  p.stereoUnpremultipliedBlend = this->StereoUnpremultipliedBlend;

  vtkImageData* outputs[2] = { vtkImageData::GetData(outputVector, 0),
    vtkImageData::GetData(outputVector, 1) };
  vtkSmartPointer<vtkFloatArray> denoised[2];
  float* targets[2] = { nullptr, nullptr };
  for (int e = 0; e < eyeCount; ++e)
  {
    // The last frame's array is reused unless someone besides this filter and its output still
    // holds it (a shallow copy of an earlier output keeps its frame). The executive has
    // usually emptied the output already (PrepareForNewData).
    denoised[e] = internals.Denoised[e];
    const int holders =
      2 + (denoised[e] && outputs[e]->GetPointData()->GetAbstractArray("Radiance") == denoised[e]);
    if (!denoised[e] || denoised[e]->GetReferenceCount() > holders)
    {
      denoised[e] = vtkSmartPointer<vtkFloatArray>::New();
      internals.Denoised[e] = denoised[e];
    }
    denoised[e]->SetName("Radiance");
    denoised[e]->SetNumberOfComponents(4);
    denoised[e]->SetNumberOfTuples(inputs[e]->GetNumberOfPoints());
    if (denoised[e]->GetNumberOfTuples() != inputs[e]->GetNumberOfPoints())
    {
      // vtkDataArray reports a failed allocation and stays empty.
      vtkErrorMacro(<< "Out of memory for the denoised image of eye " << e << " ("
                    << inputs[e]->GetNumberOfPoints()
                    << " RGBA float pixels). Denoise smaller images or free memory.");
      return 0;
    }
    targets[e] = denoised[e]->GetPointer(0);
  }
  std::string error;
  if (!internals.Denoiser.denoise(frames, eyeCount, static_cast<float>(illuminationDifference),
        targets, error, sameFrame))
  {
    vtkErrorMacro(<< error);
    return 0;
  }
  internals.HasFrame = true;
  internals.LastIlluminationDifference = illuminationDifference;
  for (int e = 0; e < 2; ++e)
  {
    internals.Inputs[e] = inputs[e];
    internals.InputTimes[e] = inputs[e] ? inputs[e]->GetMTime() : 0;
  }
  const hv::denoise::DenoiserStatistics& statistics = internals.Denoiser.statistics();
  internals.LastMilliseconds = statistics.milliseconds[5];

  for (int e = 0; e < 2; ++e)
  {
    vtkImageData* output = outputs[e];
    if (e >= eyeCount)
    {
      internals.Denoised[e] = nullptr; // a mono frame: the right eye's array is not kept
      output->Initialize();
      continue;
    }
    output->ShallowCopy(inputs[e]);
    output->GetPointData()->AddArray(denoised[e]);
    output->GetPointData()->SetActiveScalars("Radiance");
    // Own field data: the input's arrays plus this frame's figures, the input left untouched.
    vtkNew<vtkFieldData> fields;
    fields->ShallowCopy(inputs[e]->GetFieldData());
    SetFieldValue(fields, "IlluminationDifference", illuminationDifference);
    SetFieldValue(fields, "TemporalWeight", statistics.temporalGate);
    SetFieldValue(fields, "DisoccludedFraction", statistics.disoccludedFraction[e]);
    SetFieldValue(fields, "MaterialChangedFraction", statistics.materialChangedFraction[e]);
    SetFieldValue(fields, "MeanHistoryLength", statistics.meanHistoryLength[e]);
    output->SetFieldData(fields);
  }
  return 1;
}

void vtkStereoSpatioTemporalDenoiser::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "IlluminationDifference: " << this->IlluminationDifference << "\n";
  os << indent << "CrossViewSamples: " << (this->CrossViewSamples ? "On" : "Off") << "\n";
  os << indent << "TemporalAccumulation: " << (this->TemporalAccumulation ? "On" : "Off") << "\n";
  os << indent << "SpatialFilter: " << (this->SpatialFilter ? "On" : "Off") << "\n";
  os << indent << "StereoBlend: " << (this->StereoBlend ? "On" : "Off") << "\n";
  os << indent << "DemodulateAlbedo: " << (this->DemodulateAlbedo ? "On" : "Off") << "\n";
  os << indent << "RelightHistoryOnTransferFunctionChange: "
     << (this->RelightHistoryOnTransferFunctionChange ? "On" : "Off") << "\n";
  os << indent << "CoverageAgreementWidth: " << this->CoverageAgreementWidth << "\n";
  os << indent << "CrossViewCoverageWidth: " << this->CrossViewCoverageWidth << "\n";
  os << indent << "AlbedoSigma: " << this->AlbedoSigma << "\n";
  os << indent << "NormalSharpness: " << this->NormalSharpness << "\n";
  os << indent << "DepthSigma: " << this->DepthSigma << "\n";
  os << indent << "SigmoidSteepness: " << this->SigmoidSteepness << "\n";
  os << indent << "SigmoidCenter: " << this->SigmoidCenter << "\n";
  os << indent << "MaximumHistoryLength: " << this->MaximumHistoryLength << "\n";
  os << indent << "RelightingRadius: " << this->RelightingRadius << "\n";
  os << indent << "RelightingRunHeightFraction: " << this->RelightingRunHeightFraction << "\n";
  os << indent << "RelitHistoryReuse: " << this->RelitHistoryReuse << "\n";
  os << indent
     << "RelightFromPreviousLighting: " << (this->RelightFromPreviousLighting ? "On" : "Off")
     << "\n";
  os << indent << "PreviousLightingRadius: " << this->PreviousLightingRadius << "\n";
  os << indent << "PreviousLightingWeight: " << this->PreviousLightingWeight << "\n";
  os << indent << "RelitHistoryRejection: " << this->RelitHistoryRejection << "\n";
  os << indent << "RelitHistoryRejectionHistoryVariance: "
     << (this->RelitHistoryRejectionHistoryVariance ? "On" : "Off") << "\n";
  os << indent << "ClassificationScalarTolerance: " << this->ClassificationScalarTolerance << "\n";
  os << indent << "ClassificationCoverageWidth: " << this->ClassificationCoverageWidth << "\n";
  os << indent << "RelightingRefinementFrames: " << this->RelightingRefinementFrames << "\n";
  os << indent << "BicubicHistory: " << (this->BicubicHistory ? "On" : "Off") << "\n";
  os << indent << "MaximumHistoryAngle: " << this->MaximumHistoryAngle << "\n";
  os << indent << "GrazingHistoryCosine: " << this->GrazingHistoryCosine << "\n";
  os << indent << "GrazingHistoryFraction: " << this->GrazingHistoryFraction << "\n";
  os << indent << "ExponentialAverageAlpha: " << this->ExponentialAverageAlpha << "\n";
  os << indent << "DepthTolerance: " << this->DepthTolerance << "\n";
  os << indent << "SurfaceJitterTolerance: " << this->SurfaceJitterTolerance << "\n";
  os << indent << "NormalTestGradient: " << this->NormalTestGradient << "\n";
  os << indent << "NormalTolerance: " << this->NormalTolerance << "\n";
  os << indent << "ClampWidth: " << this->ClampWidth << "\n";
  os << indent << "WaveletLevels: " << this->WaveletLevels << "\n";
  os << indent << "LuminanceSigma: " << this->LuminanceSigma << "\n";
  os << indent << "WaveletAlbedoSigma: " << this->WaveletAlbedoSigma << "\n";
  os << indent << "WaveletNormalSharpness: " << this->WaveletNormalSharpness << "\n";
  os << indent << "WaveletDepthSigma: " << this->WaveletDepthSigma << "\n";
  os << indent << "WaveletNormalGradientFloor: " << this->WaveletNormalGradientFloor << "\n";
  os << indent << "HistoryNormalGradientFloor: " << this->HistoryNormalGradientFloor << "\n";
  os << indent << "WaveletAlbedoGradientWeight: " << this->WaveletAlbedoGradientWeight << "\n";
  os << indent << "WaveletLongHistory: " << this->WaveletLongHistory << "\n";
  os << indent << "WaveletDepthFromHistory: " << (this->WaveletDepthFromHistory ? "On" : "Off")
     << "\n";
  os << indent << "RemodulateByHistoryAlbedo: " << (this->RemodulateByHistoryAlbedo ? "On" : "Off")
     << "\n";
  os << indent << "HistoryAlbedoGradients: " << this->HistoryAlbedoGradients[0] << ", "
     << this->HistoryAlbedoGradients[1] << "\n";
  os << indent << "StereoAlbedoFromHistory: " << (this->StereoAlbedoFromHistory ? "On" : "Off")
     << "\n";
  os << indent << "StereoAlpha: " << this->StereoAlpha << "\n";
  os << indent << "StereoBeta: " << this->StereoBeta << "\n";
  os << indent << "StereoAgreementWidth: " << this->StereoAgreementWidth << "\n";
  os << indent << "StereoCoverageWidth: " << this->StereoCoverageWidth << "\n";
  os << indent
     << "StereoUnpremultipliedBlend: " << (this->StereoUnpremultipliedBlend ? "On" : "Off") << "\n";
  os << indent << "LastFrameMilliseconds: " << this->Internals->LastMilliseconds << "\n";
}
