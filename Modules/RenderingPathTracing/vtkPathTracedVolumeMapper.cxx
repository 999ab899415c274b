// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "vtkPathTracedVolumeMapper.h"

#include "vtkAlgorithmOutput.h"
#include "vtkArrayDispatch.h"
#include "vtkCamera.h"
#include "vtkColorTransferFunction.h"
#include "vtkCommand.h"
#include "vtkDataArray.h"
#include "vtkDataArrayRange.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkIntArray.h"
#include "vtkLight.h"
#include "vtkLightCollection.h"
#include "vtkMatrix3x3.h"
#include "vtkMatrix4x4.h"
#include "vtkObjectFactory.h"
#include "vtkOpenGLQuadHelper.h"
#include "vtkOpenGLRenderUtilities.h"
#include "vtkOpenGLRenderWindow.h"
#include "vtkOpenGLShaderCache.h"
#include "vtkOpenGLState.h"
#include "vtkPiecewiseFunction.h"
#include "vtkPlane.h"
#include "vtkPlaneCollection.h"
#include "vtkPointData.h"
#include "vtkRenderWindow.h"
#include "vtkRenderer.h"
#include "vtkSMPTools.h"
#include "vtkShaderProgram.h"
#include "vtkStereoSpatioTemporalDenoiser.h"
#include "vtkTextureObject.h"
#include "vtkTimeStamp.h"
#include "vtkUnsignedCharArray.h"
#include "vtkVolume.h"
#include "vtkVolumeProperty.h"
#include "vtk_glew.h"

#include "hv/DefaultInitAllocator.h"
#include "hv/EnvironmentMap.h"
#include "hv/Render.h"
#include "hv/ToneMapping.h"
#include "hv/VolumeGrid.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <vector>

namespace
{
constexpr int TransferFunctionTableSize = 1024;
constexpr int GradientOpacityTableSize = 256;

glm::mat4 ToGlm(const vtkMatrix4x4* m)
{
  glm::mat4 result;
  for (int row = 0; row < 4; ++row)
  {
    for (int column = 0; column < 4; ++column)
    {
      result[column][row] = static_cast<float>(m->GetElement(row, column));
    }
  }
  return result;
}

// Settings that change the rendered image; a change restarts the accumulation.
struct RenderSettings
{
  int IlluminationModel;
  int MaximumBounces;
  int RussianRouletteStartBounce;
  double SecondaryRayRoulette;
  double Anisotropy;
  double DensityScale;
  double SurfaceScatteringFactor;
  vtkTypeUInt32 Seed;
  bool StratifiedSubpixelSamples;
  double EnvironmentRadiance[3];
  double EnvironmentIntensity;
  bool EnvironmentVisible;
  bool EnvironmentImportanceSampling;
  bool UseRendererLights;
  double StepLengthFactor;
  int MacrocellSize;
  int Cropping;
  int CroppingRegionFlags;
  double CroppingRegionPlanes[6];

  bool operator==(const RenderSettings& other) const
  {
    return std::memcmp(this, &other, sizeof(RenderSettings)) == 0;
  }
};

// Converts any scalar type to the grid's 16-bit fixed point of the scalar normalised over its
// range, on every core.
struct QuantizeScalarsWorker
{
  template <typename ArrayType>
  void operator()(ArrayType* array, std::uint16_t* out, double low, double scale)
  {
    const auto values = vtk::DataArrayValueRange<1>(array);
    vtkSMPTools::For(0, static_cast<vtkIdType>(values.size()),
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType i = begin; i < end; ++i)
        {
          out[i] = hv::VolumeGrid::quantize(
            static_cast<float>((static_cast<double>(values[i]) - low) * scale));
        }
      });
  }
};
}

class vtkPathTracedVolumeMapper::vtkInternals
{
public:
  struct EyeState
  {
    // Sized without a value: a frame that starts the sum writes it rather than adds to it.
    std::vector<float, hv::DefaultInitAllocator<float>> RadianceSum;
    int AccumulatedFrames = 0;
    glm::mat4 View = glm::mat4(0.0f);
    glm::mat4 Projection = glm::mat4(0.0f);
    vtkMTimeType SceneKey = 0;
    RenderSettings Settings{};
    vtkNew<vtkImageData> Output;
    bool Valid = false;
    // The environment and lights of the eye's last frame, for RenderPreviousLighting. The view's
    // texels belong to the map of generation LastEnvironmentGeneration (-1: none rendered).
    hv::EnvironmentView LastEnvironment;
    int LastEnvironmentGeneration = -1;
    hv::PointLightView LastLights[hv::MaximumLights];
    int LastLightCount = 0;
  };

  hv::VolumeGrid Grid;
  hv::EnvironmentMap Environment;
  // With RenderPreviousLighting, the map Environment held before its last change (its texels
  // are what the eyes' LastEnvironment views point at until they render under the new one), and
  // which generation that was. The generation counts changes of Environment's texels.
  hv::EnvironmentMap PreviousEnvironment;
  int EnvironmentGeneration = 0;
  int PreviousEnvironmentGeneration = -1;
  // Before Environment's texels are replaced or cleared: keeps them for the eyes' previous
  // lighting, or lets the eyes know they are gone.
  void RetireEnvironment(bool keep)
  {
    if (keep)
    {
      std::swap(this->Environment, this->PreviousEnvironment);
      this->PreviousEnvironmentGeneration = this->EnvironmentGeneration;
    }
    else
    {
      this->PreviousEnvironment = hv::EnvironmentMap();
      this->PreviousEnvironmentGeneration = -1;
    }
    ++this->EnvironmentGeneration;
  }
  // Whether an eye's last frame was lit by another environment than `scene`'s that is still
  // held, with the same renderer lights (their change is not shaded twice).
  bool PreviousLightingChanged(const EyeState& state, const hv::SceneView& scene) const
  {
    const int generation = state.LastEnvironmentGeneration;
    if (generation < 0 ||
      (generation != this->EnvironmentGeneration &&
        generation != this->PreviousEnvironmentGeneration))
    {
      return false;
    }
    if (state.LastLightCount != scene.lightCount ||
      std::memcmp(state.LastLights, scene.lights,
        sizeof(hv::PointLightView) * static_cast<std::size_t>(scene.lightCount)) != 0)
    {
      return false;
    }
    const hv::EnvironmentView& last = state.LastEnvironment;
    const hv::EnvironmentView& now = scene.environment;
    return generation != this->EnvironmentGeneration || last.scale != now.scale ||
      last.worldToMap != now.worldToMap ||
      (now.isUniform() && last.uniformRadiance != now.uniformRadiance);
  }
  vtkImageData* ScalarsInput = nullptr;
  vtkMTimeType ScalarsTime = 0;
  double ScalarRange[2] = { 0.0, 1.0 };
  int Extent[6] = { 0, -1, 0, -1, 0, -1 };
  vtkMTimeType TransferTime = 0;
  double TransferDensityScale = -1.0;
  int TransferCellSize = 0;
  bool TransferGradientOpacity = false;
  bool Transparent = false;
  vtkImageData* EnvironmentInput = nullptr;
  vtkMTimeType EnvironmentTime = 0;
  bool EnvironmentValid = false;
  vtkMTimeType SceneKey = 0;
  int ClassificationStamp = 0;
  int DataStamp = 0;                        // changes with the scalars alone
  // What the last classification produced. The property's MTime also moves when nothing in it
  // changed (vtkVolume::SetProperty calls UpdateMTimes() on it, so putting a property on a
  // second volume touches it), and a new ClassificationStamp makes a denoiser drop its history:
  // the stamp changes only when the tables (or the data) do.
  std::vector<float> ClassifiedOpacity, ClassifiedAlbedo, ClassifiedGradientTable;
  float ClassifiedUnitDistance = -1.0f;
  float ClassifiedDensityScale = -1.0f;
  float ClassifiedMaximumGradient = -1.0f;
  int ClassifiedDataStamp = -1;
  // When what the property puts into the frame last changed (the classification above and the
  // shading coefficients), for SceneKey: the property's own MTime moves without a change too,
  // and progressive accumulation would restart on it.
  vtkTimeStamp PropertyContentTime;
  std::array<float, 4> ShadingCoefficients = { -1.0f, -1.0f, -1.0f, -1.0f };
  glm::mat4 VolumeMatrix = glm::mat4(1.0f); // the prop's matrix: world from volume
  std::array<EyeState, 2> Eyes;
  // The right eye's matrices of the last denoised stereo window frame, whose second pass
  // shows it without rendering again.
  glm::mat4 DenoisedRightView = glm::mat4(0.0f);
  glm::mat4 DenoisedRightProjection = glm::mat4(0.0f);
  bool DenoisedRightReady = false;

  vtkTextureObject* Texture = nullptr;
  vtkOpenGLQuadHelper* Quad = nullptr;
  std::vector<unsigned char> DisplayPixels;

  ~vtkInternals()
  {
    delete this->Quad;
    if (this->Texture)
    {
      this->Texture->Delete();
    }
  }
};

vtkStandardNewMacro(vtkPathTracedVolumeMapper);

vtkPathTracedVolumeMapper::vtkPathTracedVolumeMapper()
  : Internals(new vtkInternals)
{
  this->SetNumberOfInputPorts(2);
  this->EnvironmentToWorldMatrix = vtkMatrix4x4::New();
  // Loading a volume and changing its transfer function rebuild the grid's per-voxel and
  // per-cell arrays; on every core, as the frames are rendered.
  this->Internals->Grid.setParallelFor(
    [](std::int64_t count, const std::function<void(std::int64_t, std::int64_t)>& body)
    {
      vtkSMPTools::For(0, static_cast<vtkIdType>(count),
        [&body](vtkIdType begin, vtkIdType end) { body(begin, end); });
    });
}

vtkPathTracedVolumeMapper::~vtkPathTracedVolumeMapper()
{
  this->EnvironmentToWorldMatrix->Delete();
  this->SetDenoiser(nullptr);
}

void vtkPathTracedVolumeMapper::SetDenoiser(vtkStereoSpatioTemporalDenoiser* denoiser)
{
  if (this->Denoiser == denoiser)
  {
    return;
  }
  if (this->Denoiser)
  {
    this->Denoiser->UnRegister(this);
  }
  this->Denoiser = denoiser;
  if (this->Denoiser)
  {
    this->Denoiser->Register(this);
  }
  this->Internals->DenoisedRightReady = false;
  this->Modified();
}

int vtkPathTracedVolumeMapper::FillInputPortInformation(int port, vtkInformation* info)
{
  if (port == 1)
  {
    info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
    info->Set(vtkAlgorithm::INPUT_IS_OPTIONAL(), 1);
    return 1;
  }
  return this->Superclass::FillInputPortInformation(port, info);
}

void vtkPathTracedVolumeMapper::SetEnvironmentMapConnection(vtkAlgorithmOutput* output)
{
  this->SetInputConnection(1, output);
}

void vtkPathTracedVolumeMapper::SetEnvironmentMapData(vtkImageData* image)
{
  this->SetInputDataInternal(1, image);
}

vtkImageData* vtkPathTracedVolumeMapper::GetEnvironmentMap()
{
  if (this->GetNumberOfInputConnections(1) < 1)
  {
    return nullptr;
  }
  return vtkImageData::SafeDownCast(this->GetInputDataObject(1, 0));
}

void vtkPathTracedVolumeMapper::SetEnvironmentToWorldMatrix(vtkMatrix4x4* matrix)
{
  if (matrix)
  {
    this->EnvironmentToWorldMatrix->DeepCopy(matrix);
  }
  else
  {
    this->EnvironmentToWorldMatrix->Identity();
  }
  this->Modified();
}

vtkMTimeType vtkPathTracedVolumeMapper::GetMTime()
{
  return std::max(this->Superclass::GetMTime(), this->EnvironmentToWorldMatrix->GetMTime());
}

const char* vtkPathTracedVolumeMapper::GetIlluminationModelAsString()
{
  switch (this->IlluminationModel)
  {
    case EMISSION_ABSORPTION:
      return "EmissionAbsorption";
    case GRADIENT_PHONG:
      return "GradientPhong";
    case PREFILTERED_ENVIRONMENT:
      return "PrefilteredEnvironment";
    default:
      return "PathTraced";
  }
}

void vtkPathTracedVolumeMapper::ResetAccumulation()
{
  for (auto& eye : this->Internals->Eyes)
  {
    eye.AccumulatedFrames = 0;
  }
}

int vtkPathTracedVolumeMapper::GetAccumulatedFrames(int eye)
{
  return (eye == 0 || eye == 1) ? this->Internals->Eyes[eye].AccumulatedFrames : 0;
}

vtkImageData* vtkPathTracedVolumeMapper::GetEyeOutput(int eye)
{
  if (eye != 0 && eye != 1)
  {
    vtkErrorMacro("GetEyeOutput(" << eye << "): the eye must be 0 (left or mono) or 1 (right).");
    return nullptr;
  }
  return this->Internals->Eyes[eye].Output;
}

namespace
{
bool ReportInputProblem(
  vtkPathTracedVolumeMapper* self, vtkImageData* input, vtkDataArray*& scalars)
{
  scalars = nullptr;
  if (!input)
  {
    vtkErrorWithObjectMacro(
      self, "No input volume: connect a vtkImageData with SetInputConnection() or SetInputData().");
    return false;
  }
  int dims[3];
  input->GetDimensions(dims);
  if (dims[0] < 2 || dims[1] < 2 || dims[2] < 2)
  {
    vtkErrorWithObjectMacro(self,
      "The input volume has dimensions " << dims[0] << "x" << dims[1] << "x" << dims[2]
                                         << "; path tracing needs at least 2 "
                                            "samples along each axis (an empty "
                                            "extent or a 2D image cannot be rendered).");
    return false;
  }
  scalars = input->GetPointData()->GetScalars();
  if (!scalars)
  {
    vtkErrorWithObjectMacro(self,
      "The input volume has no point scalars: set the array to render as the active scalars "
      "(vtkImageData::GetPointData()->SetActiveScalars(name)).");
    return false;
  }
  if (scalars->GetNumberOfComponents() != 1)
  {
    vtkErrorWithObjectMacro(self,
      "The input scalars '" << (scalars->GetName() ? scalars->GetName() : "") << "' have "
                            << scalars->GetNumberOfComponents()
                            << " components; the mapper renders single-component "
                               "data. Extract one with vtkImageExtractComponents or "
                               "compute a magnitude with vtkImageMagnitude first.");
    return false;
  }
  return true;
}
}

namespace
{
// Continuous kernel index -> structured index (the extent's start) -> physical -> world.
glm::mat4 IndexToWorld(vtkImageData* input, vtkVolume* volume)
{
  int extent[6];
  input->GetExtent(extent);
  vtkNew<vtkMatrix4x4> shift;
  for (int axis = 0; axis < 3; ++axis)
  {
    shift->SetElement(axis, 3, extent[2 * axis]);
  }
  vtkNew<vtkMatrix4x4> indexToPhysical;
  input->ComputeIndexToPhysicalMatrix(input->GetOrigin(), input->GetSpacing(),
    input->GetDirectionMatrix()->GetData(), indexToPhysical->GetData());
  vtkMatrix4x4::Multiply4x4(indexToPhysical, shift, indexToPhysical);
  vtkNew<vtkMatrix4x4> indexToWorld;
  vtkMatrix4x4::Multiply4x4(volume->GetMatrix(), indexToPhysical, indexToWorld);
  return ToGlm(indexToWorld);
}
}

// Prepares the kernel scene from the input, property, environment, lights and settings.
// Returns false (after reporting why) when nothing can be rendered.
bool vtkPathTracedVolumeMapper::PrepareScene(
  vtkVolume* volume, vtkLightCollection* lights, hv::SceneView& scene)
{
  vtkPathTracedVolumeMapper* self = this;
  vtkInternals* internals = this->Internals.get();
  if (!volume)
  {
    vtkErrorWithObjectMacro(
      self, "No vtkVolume given: the mapper needs the volume's property and matrix.");
    return false;
  }
  if (self->GetNumberOfInputConnections(0) > 0 && self->GetInputAlgorithm(0, 0))
  {
    self->GetInputAlgorithm(0, 0)->Update();
  }
  if (self->GetNumberOfInputConnections(1) > 0 && self->GetInputAlgorithm(1, 0))
  {
    self->GetInputAlgorithm(1, 0)->Update();
  }
  vtkImageData* input = vtkImageData::SafeDownCast(self->GetInput());
  vtkDataArray* scalars = nullptr;
  if (!ReportInputProblem(self, input, scalars))
  {
    return false;
  }
  vtkVolumeProperty* property = volume->GetProperty();

  // 1. Scalars, normalised over their range.
  const vtkMTimeType scalarsTime = std::max(input->GetMTime(), scalars->GetMTime());
  if (internals->ScalarsInput != input || internals->ScalarsTime != scalarsTime)
  {
    double range[2];
    scalars->GetRange(range, 0);
    if (!std::isfinite(range[0]) || !std::isfinite(range[1]))
    {
      vtkErrorWithObjectMacro(self,
        "The input scalars contain NaN or infinite values; replace them "
        "(e.g. with vtkImageThreshold) before rendering.");
      return false;
    }
    const double scale = range[1] > range[0] ? 1.0 / (range[1] - range[0]) : 0.0;
    int dims[3];
    input->GetDimensions(dims);
    // Sized without a value: the worker's threads write it first.
    hv::VolumeGrid::ScalarArray quantized;
    quantized.resize(static_cast<std::size_t>(dims[0]) * dims[1] * dims[2]);
    QuantizeScalarsWorker worker;
    if (!vtkArrayDispatch::Dispatch::Execute(scalars, worker, quantized.data(), range[0], scale))
    {
      worker(scalars, quantized.data(), range[0], scale);
    }
    // With their matrix: the grid searches the voxels for the largest world gradient magnitude
    // as it takes them, and under the matrix it held (another spacing) step 2 would search again.
    internals->Grid.setQuantizedScalars(
      glm::ivec3(dims[0], dims[1], dims[2]), std::move(quantized), IndexToWorld(input, volume));
    internals->ScalarRange[0] = range[0];
    internals->ScalarRange[1] = range[1];
    input->GetExtent(internals->Extent);
    internals->ScalarsInput = input;
    internals->ScalarsTime = scalarsTime;
    ++internals->DataStamp;
    internals->TransferTime = 0; // force reclassification
  }

  // 2. Geometry.
  const glm::mat4 indexToWorldGlm = IndexToWorld(input, volume);
  internals->VolumeMatrix = ToGlm(volume->GetMatrix());
  const bool gradientsChanged = internals->Grid.setIndexToWorld(indexToWorldGlm);

  // 3. Classification: the transfer functions as tables over the scalar range.
  const bool gradientOpacity =
    property->HasGradientOpacity(0) && !property->GetDisableGradientOpacity(0);
  if (internals->TransferTime != property->GetMTime() ||
    internals->TransferDensityScale != self->GetDensityScale() ||
    internals->TransferCellSize != self->GetMacrocellSize() ||
    (gradientOpacity && gradientsChanged) || gradientOpacity != internals->TransferGradientOpacity)
  {
    const double* range = internals->ScalarRange;
    std::vector<float> opacity(TransferFunctionTableSize);
    std::vector<float> albedo(3 * TransferFunctionTableSize);
    const double high = range[1] > range[0] ? range[1] : range[0] + 1.0;
    property->GetScalarOpacity(0)->GetTable(
      range[0], high, TransferFunctionTableSize, opacity.data());
    if (property->GetColorChannels(0) == 3)
    {
      property->GetRGBTransferFunction(0)->GetTable(
        range[0], high, TransferFunctionTableSize, albedo.data());
    }
    else
    {
      std::vector<float> gray(TransferFunctionTableSize);
      property->GetGrayTransferFunction(0)->GetTable(
        range[0], high, TransferFunctionTableSize, gray.data());
      for (int i = 0; i < TransferFunctionTableSize; ++i)
      {
        albedo[3 * i] = albedo[3 * i + 1] = albedo[3 * i + 2] = gray[i];
      }
    }
    for (float& a : albedo)
    {
      a = std::min(std::max(a, 0.0f), 1.0f); // an albedo above one would create energy
    }
    const float unitDistance =
      static_cast<float>(std::max(property->GetScalarOpacityUnitDistance(0), 1e-12));
    const float densityScale = static_cast<float>(self->GetDensityScale());
    std::vector<float> gradientTable;
    const float scalarSpan = static_cast<float>(range[1] - range[0]);
    const float maximumRawGradient = internals->Grid.maximumGradientMagnitude() * scalarSpan;
    if (gradientOpacity)
    {
      gradientTable.resize(GradientOpacityTableSize);
      property->GetGradientOpacity(0)->GetTable(
        0.0, std::max(maximumRawGradient, 1e-12f), GradientOpacityTableSize, gradientTable.data());
    }
    const bool sameClassification = internals->ClassifiedDataStamp == internals->DataStamp &&
      opacity == internals->ClassifiedOpacity && albedo == internals->ClassifiedAlbedo &&
      gradientTable == internals->ClassifiedGradientTable &&
      unitDistance == internals->ClassifiedUnitDistance &&
      densityScale == internals->ClassifiedDensityScale &&
      maximumRawGradient == internals->ClassifiedMaximumGradient;
    if (!sameClassification || internals->TransferCellSize != self->GetMacrocellSize())
    {
      internals->Grid.setCellSize(self->GetMacrocellSize());
      internals->Grid.setTransferFunction(opacity, albedo, unitDistance, densityScale);
      internals->Grid.setGradientOpacity(gradientTable, maximumRawGradient, scalarSpan);
      internals->Transparent = internals->Grid.isTransparent();
      if (internals->Transparent)
      {
        vtkWarningWithObjectMacro(self,
          "The scalar opacity transfer function (times DensityScale "
            << self->GetDensityScale() << ") is zero over the data range [" << range[0] << ", "
            << range[1] << "]: the volume is invisible. Add opacity points inside the data range.");
      }
    }
    if (!sameClassification)
    {
      ++internals->ClassificationStamp;
      internals->PropertyContentTime.Modified();
      internals->ClassifiedOpacity = std::move(opacity);
      internals->ClassifiedAlbedo = std::move(albedo);
      internals->ClassifiedGradientTable = std::move(gradientTable);
      internals->ClassifiedUnitDistance = unitDistance;
      internals->ClassifiedDensityScale = densityScale;
      internals->ClassifiedMaximumGradient = maximumRawGradient;
      internals->ClassifiedDataStamp = internals->DataStamp;
    }
    internals->TransferTime = property->GetMTime();
    internals->TransferDensityScale = self->GetDensityScale();
    internals->TransferCellSize = self->GetMacrocellSize();
    internals->TransferGradientOpacity = gradientOpacity;
  }

  // 4. Cropping (VTK's 27 regions; region planes in data coordinates).
  {
    double planes[6];
    self->GetCroppingRegionPlanes(planes);
    glm::vec3 low, high;
    const double* origin = input->GetOrigin();
    const double* spacing = input->GetSpacing();
    for (int axis = 0; axis < 3; ++axis)
    {
      low[axis] = static_cast<float>(
        (planes[2 * axis] - origin[axis]) / spacing[axis] - internals->Extent[2 * axis]);
      high[axis] = static_cast<float>(
        (planes[2 * axis + 1] - origin[axis]) / spacing[axis] - internals->Extent[2 * axis]);
      if (low[axis] > high[axis])
      {
        std::swap(low[axis], high[axis]);
      }
    }
    internals->Grid.setCropping(
      self->GetCropping() != 0, low, high, self->GetCroppingRegionFlags());
  }
  internals->Grid.setSurfaceFactor(static_cast<float>(self->GetSurfaceScatteringFactor()));
  scene.volume = internals->Grid.view();

  // 5. Clipping planes, world coordinates; the kept side is where the normal points.
  scene.clipping.count = 0;
  vtkMTimeType planesTime = 0;
  if (vtkPlaneCollection* planes = self->GetClippingPlanes())
  {
    planesTime = planes->GetMTime();
    if (planes->GetNumberOfItems() > hv::MaximumClippingPlanes)
    {
      vtkWarningWithObjectMacro(self,
        "Only the first " << hv::MaximumClippingPlanes << " of " << planes->GetNumberOfItems()
                          << " clipping planes are used.");
    }
    for (int i = 0; i < std::min(planes->GetNumberOfItems(), hv::MaximumClippingPlanes); ++i)
    {
      vtkPlane* plane = planes->GetItem(i);
      planesTime = std::max(planesTime, plane->GetMTime());
      double normal[3], origin[3];
      plane->GetNormal(normal);
      plane->GetOrigin(origin);
      const glm::vec3 n(normal[0], normal[1], normal[2]);
      const float length = glm::length(n);
      if (length <= 0.0f)
      {
        continue;
      }
      const glm::vec3 unit = n / length;
      scene.clipping.planes[scene.clipping.count++] =
        glm::vec4(unit, -glm::dot(unit, glm::vec3(origin[0], origin[1], origin[2])));
    }
  }

  // 6. Environment.
  vtkImageData* map = self->GetEnvironmentMap();
  vtkMTimeType environmentTime = 0;
  if (map)
  {
    environmentTime = map->GetMTime();
    if (map != internals->EnvironmentInput || environmentTime != internals->EnvironmentTime)
    {
      internals->EnvironmentInput = map;
      internals->EnvironmentTime = environmentTime;
      internals->EnvironmentValid = false;
      internals->RetireEnvironment(self->GetRenderPreviousLighting());
      vtkDataArray* radiance = map->GetPointData()->GetScalars();
      int dims[3];
      map->GetDimensions(dims);
      if (!radiance || radiance->GetNumberOfComponents() < 3 || dims[2] != 1)
      {
        vtkErrorWithObjectMacro(self,
          "The environment map must be a 2D vtkImageData with RGB or RGBA point "
          "scalars (linear radiance); using the uniform environment instead.");
        internals->Environment.clearRadiance();
      }
      else
      {
        const int width = dims[0];
        const int height = dims[1];
        std::vector<float> rgb(static_cast<std::size_t>(width) * height * 3);
        // VTK images start with the bottom row; the kernels' maps start at the zenith.
        vtkSMPTools::For(0, height,
          [&](vtkIdType begin, vtkIdType end)
          {
            for (vtkIdType j = begin; j < end; ++j)
            {
              for (int i = 0; i < width; ++i)
              {
                const vtkIdType source = j * width + i;
                float* target =
                  rgb.data() + 3 * ((static_cast<std::size_t>(height - 1 - j)) * width + i);
                for (int c = 0; c < 3; ++c)
                {
                  target[c] = static_cast<float>(radiance->GetComponent(source, c));
                }
              }
            }
          });
        const std::string problem =
          internals->Environment.setRadiance(width, height, std::move(rgb));
        if (!problem.empty())
        {
          vtkErrorWithObjectMacro(self,
            "Unusable environment map: " << problem << ". Using the uniform environment instead.");
          internals->Environment.clearRadiance();
        }
        else
        {
          internals->EnvironmentValid = true;
        }
      }
    }
  }
  else if (internals->EnvironmentInput)
  {
    internals->EnvironmentInput = nullptr;
    internals->EnvironmentValid = false;
    internals->RetireEnvironment(self->GetRenderPreviousLighting());
    internals->Environment.clearRadiance();
  }
  const double* uniform = self->GetEnvironmentRadiance();
  internals->Environment.setUniformRadiance(glm::vec3(uniform[0], uniform[1], uniform[2]));
  internals->Environment.setScale(static_cast<float>(self->GetEnvironmentIntensity()));
  internals->Environment.setImportanceSampling(self->GetEnvironmentImportanceSampling());
  internals->Environment.setWorldToMap(
    glm::transpose(glm::mat3(ToGlm(self->GetEnvironmentToWorldMatrix()))));
  scene.environment = internals->Environment.view();
  internals->Environment.sphericalHarmonics(scene.irradianceSH);

  // 7. Lights, in world coordinates (the renderer has already placed camera lights).
  scene.lightCount = 0;
  vtkMTimeType lightsTime = 0;
  if (lights && self->GetUseRendererLights())
  {
    lights->InitTraversal();
    for (vtkLight* light = lights->GetNextItem(); light; light = lights->GetNextItem())
    {
      lightsTime = std::max(lightsTime, light->GetMTime());
      if (!light->GetSwitch() || light->GetIntensity() <= 0.0)
      {
        continue;
      }
      if (scene.lightCount == hv::MaximumLights)
      {
        vtkWarningWithObjectMacro(
          self, "Only the first " << hv::MaximumLights << " lights are used.");
        break;
      }
      hv::PointLightView& target = scene.lights[scene.lightCount++];
      double position[3], focal[3], color[3];
      light->GetTransformedPosition(position);
      light->GetTransformedFocalPoint(focal);
      light->GetDiffuseColor(color);
      target.intensity =
        static_cast<float>(light->GetIntensity()) * glm::vec3(color[0], color[1], color[2]);
      const glm::vec3 p(position[0], position[1], position[2]);
      const glm::vec3 f(focal[0], focal[1], focal[2]);
      const glm::vec3 axis = glm::length(p - f) > 0.0f ? glm::normalize(p - f) : glm::vec3(0, 0, 1);
      if (light->GetPositional())
      {
        target.type = hv::PositionalLight;
        target.position = p;
        target.spotDirection = -axis;
        const double* attenuation = light->GetAttenuationValues();
        target.attenuation = glm::vec3(attenuation[0], attenuation[1], attenuation[2]);
        if (light->GetConeAngle() < 90.0)
        {
          target.spotCosCutoff =
            static_cast<float>(std::cos(vtkMath::RadiansFromDegrees(light->GetConeAngle())));
          target.spotExponent = static_cast<float>(light->GetExponent());
        }
      }
      else
      {
        target.type = hv::DirectionalLight;
        target.toLight = axis;
      }
    }
  }

  // 8. Settings.
  scene.model = self->GetIlluminationModel();
  scene.maximumBounces = self->GetMaximumBounces();
  scene.rouletteStartBounce = self->GetRussianRouletteStartBounce();
  scene.secondaryRayRoulette = static_cast<float>(self->GetSecondaryRayRoulette());
  scene.stratifiedSubpixelSamples = self->GetStratifiedSubpixelSamples();
  scene.anisotropy = static_cast<float>(self->GetAnisotropy());
  scene.environmentVisible = self->GetEnvironmentVisible();
  double spacing[3];
  input->GetSpacing(spacing);
  scene.stepLength = static_cast<float>(self->GetStepLengthFactor() *
    std::min({ std::abs(spacing[0]), std::abs(spacing[1]), std::abs(spacing[2]) }));
  scene.ambient = static_cast<float>(property->GetAmbient(0));
  scene.diffuse = static_cast<float>(property->GetDiffuse(0));
  scene.specular = static_cast<float>(property->GetSpecular(0));
  scene.specularPower = static_cast<float>(property->GetSpecularPower(0));

  const std::array<float, 4> shading = { scene.ambient, scene.diffuse, scene.specular,
    scene.specularPower };
  if (shading != internals->ShadingCoefficients)
  {
    internals->ShadingCoefficients = shading;
    internals->PropertyContentTime.Modified();
  }
  // The property by what it holds, not its MTime; and the volume's own MTime, not vtkVolume's,
  // which includes the property's.
  internals->SceneKey = std::max({ scalarsTime, internals->PropertyContentTime.GetMTime(),
    volume->vtkProp3D::GetMTime(), volume->GetMatrix()->GetMTime(), environmentTime,
    self->GetEnvironmentToWorldMatrix()->GetMTime(), lightsTime, planesTime });
  return true;
}

namespace
{
RenderSettings CurrentSettings(vtkPathTracedVolumeMapper* self)
{
  RenderSettings settings;
  std::memset(&settings, 0, sizeof(settings)); // padding too, for memcmp
  settings.IlluminationModel = self->GetIlluminationModel();
  settings.MaximumBounces = self->GetMaximumBounces();
  settings.RussianRouletteStartBounce = self->GetRussianRouletteStartBounce();
  settings.SecondaryRayRoulette = self->GetSecondaryRayRoulette();
  settings.Anisotropy = self->GetAnisotropy();
  settings.DensityScale = self->GetDensityScale();
  settings.SurfaceScatteringFactor = self->GetSurfaceScatteringFactor();
  settings.Seed = self->GetSeed();
  settings.StratifiedSubpixelSamples = self->GetStratifiedSubpixelSamples();
  self->GetEnvironmentRadiance(settings.EnvironmentRadiance);
  settings.EnvironmentIntensity = self->GetEnvironmentIntensity();
  settings.EnvironmentVisible = self->GetEnvironmentVisible();
  settings.EnvironmentImportanceSampling = self->GetEnvironmentImportanceSampling();
  settings.UseRendererLights = self->GetUseRendererLights();
  settings.StepLengthFactor = self->GetStepLengthFactor();
  settings.MacrocellSize = self->GetMacrocellSize();
  settings.Cropping = self->GetCropping();
  settings.CroppingRegionFlags = self->GetCroppingRegionFlags();
  self->GetCroppingRegionPlanes(settings.CroppingRegionPlanes);
  return settings;
}

vtkFloatArray* OutputArray(vtkImageData* image, const char* name, int components, vtkIdType count)
{
  vtkFloatArray* array = vtkFloatArray::SafeDownCast(image->GetPointData()->GetArray(name));
  if (!array)
  {
    vtkNew<vtkFloatArray> created;
    created->SetName(name);
    image->GetPointData()->AddArray(created);
    array = created;
  }
  array->SetNumberOfComponents(components);
  array->SetNumberOfTuples(count);
  return array;
}

void SetFieldMatrix(vtkImageData* image, const char* name, const glm::mat4& m)
{
  vtkNew<vtkDoubleArray> array;
  array->SetName(name);
  array->SetNumberOfTuples(16);
  for (int row = 0; row < 4; ++row)
  {
    for (int column = 0; column < 4; ++column)
    {
      array->SetValue(4 * row + column, m[column][row]);
    }
  }
  image->GetFieldData()->AddArray(array);
}

void SetFieldInt(vtkImageData* image, const char* name, int value)
{
  vtkNew<vtkIntArray> array;
  array->SetName(name);
  array->SetNumberOfTuples(1);
  array->SetValue(0, value);
  image->GetFieldData()->AddArray(array);
}

// One eye's per-pixel outputs and the running radiance sum of progressive accumulation.
struct EyeBuffers
{
  float* radianceSum;
  bool sumStarts; // the first frame of the sum: its values replace what the array holds
  float* radiance;
  float* position;
  float* depth;
  float* albedo;
  float* normal;
  float* gradient;
  float* scalar;
  unsigned char* valid;
  float* previousLight; // nullptr unless the frame shades the previous environment
};

// The path tracer's inner loop, compiled twice: for x86-64-v3 (AVX2, FMA) and for the
// baseline instruction set; the loader picks the one the CPU runs (GCC function
// multiversioning, as LightingCore's HV_SIMD_CLONES does for its pixel loops; here the FMA of
// x86-64-v3 is wanted too). `flatten` inlines the whole per-pixel kernel into each version,
// so no baseline copy of it is called from the x86-64-v3 one. Measured on the head-MRI benchmark:
// 9 % less time per stereo frame. Every pixel is computed the same way in both versions, so
// images do not depend on the thread count either way.
#if defined(__x86_64__) && defined(__linux__) && defined(__GNUC__) && !defined(__clang__)
#define HV_RENDER_CLONES __attribute__((flatten, target_clones("arch=x86-64-v3", "default")))
#else
#define HV_RENDER_CLONES
#endif

HV_RENDER_CLONES void RenderRows(const hv::SceneView& scene, const hv::EyeView& view,
  const int rectangle[4], vtkIdType rowBegin, vtkIdType rowEnd, std::uint32_t eyeIndex,
  std::uint32_t frameIndex, std::uint64_t seed, int samplesPerPixel, float inverseFrames,
  const EyeBuffers& out)
{
  for (vtkIdType y = rowBegin; y < rowEnd; ++y)
  {
    for (int x = 0; x < view.width; ++x)
    {
      const vtkIdType pixel = y * view.width + x;
      const bool inside =
        x >= rectangle[0] && x < rectangle[2] && y >= rectangle[1] && y < rectangle[3];
      const hv::PixelResult r = inside ? hv::renderPixel(scene, view, x, static_cast<int>(y),
                                           eyeIndex, frameIndex, seed, samplesPerPixel)
                                       : hv::PixelResult();
      for (int c = 0; c < 4; ++c)
      {
        out.radianceSum[4 * pixel + c] =
          out.sumStarts ? r.radiance[c] : out.radianceSum[4 * pixel + c] + r.radiance[c];
        out.radiance[4 * pixel + c] = out.radianceSum[4 * pixel + c] * inverseFrames;
      }
      if (out.previousLight)
      {
        for (int c = 0; c < 3; ++c)
        {
          out.previousLight[3 * pixel + c] = r.previousLightRadiance[c];
        }
      }
      out.valid[pixel] = static_cast<unsigned char>(r.hit);
      out.depth[pixel] = r.hit ? r.depth : 0.0f;
      out.gradient[pixel] = r.gradientMagnitude;
      out.scalar[pixel] = r.scalar;
      for (int c = 0; c < 3; ++c)
      {
        out.position[3 * pixel + c] = r.firstScatterPosition[c];
        out.albedo[3 * pixel + c] = r.albedo[c];
        out.normal[3 * pixel + c] = r.normal[c];
      }
    }
  }
}
}

// Renders `eyeCount` eyes with the prepared scene; progress spans all of them.
void vtkPathTracedVolumeMapper::RenderEyes(const hv::SceneView& scene, const int* eyeIndices,
  const hv::EyeView* views, int eyeCount, vtkTypeUInt32 frameIndex)
{
  vtkPathTracedVolumeMapper* self = this;
  vtkInternals* internals = this->Internals.get();
  const RenderSettings settings = CurrentSettings(self);
  const int samplesPerPixel = self->GetSamplesPerPixel();
  const std::uint64_t seed = self->GetSeed();
  // Rows are rendered in bands so progress can be reported from the calling thread.
  constexpr int bandsPerEye = 16;
  self->InvokeEvent(vtkCommand::StartEvent);
  self->UpdateProgress(0.0);
  for (int e = 0; e < eyeCount; ++e)
  {
    const int eyeIndex = eyeIndices[e];
    const hv::EyeView& view = views[e];
    auto& state = internals->Eyes[eyeIndex];
    const vtkIdType pixelCount = static_cast<vtkIdType>(view.width) * view.height;
    vtkImageData* output = state.Output;
    int dims[3];
    output->GetDimensions(dims);
    // With a denoiser attached, each frame is fresh: the denoiser accumulates over time.
    const bool restart = !self->GetProgressiveAccumulation() || self->Denoiser || !state.Valid ||
      dims[0] != view.width || dims[1] != view.height || state.View != view.view ||
      state.Projection != view.projection || state.SceneKey != internals->SceneKey ||
      !(state.Settings == settings);
    if (restart)
    {
      state.AccumulatedFrames = 0;
    }
    // A fresh sum is written by the render loop's threads, not zeroed here first: with a
    // denoiser every frame is fresh, and zeroing 22 MB an eye at 1440x936 on this thread took
    // its first page faults on one core.
    state.RadianceSum.resize(4 * pixelCount);
    if (dims[0] != view.width || dims[1] != view.height)
    {
      output->SetDimensions(view.width, view.height, 1);
    }
    EyeBuffers buffers;
    buffers.radiance = OutputArray(output, "Radiance", 4, pixelCount)->GetPointer(0);
    buffers.position = OutputArray(output, "FirstScatterPosition", 3, pixelCount)->GetPointer(0);
    buffers.depth = OutputArray(output, "Depth", 1, pixelCount)->GetPointer(0);
    buffers.albedo = OutputArray(output, "Albedo", 3, pixelCount)->GetPointer(0);
    buffers.normal = OutputArray(output, "Normal", 3, pixelCount)->GetPointer(0);
    buffers.gradient = OutputArray(output, "GradientMagnitude", 1, pixelCount)->GetPointer(0);
    buffers.scalar = OutputArray(output, "FirstScatterScalar", 1, pixelCount)->GetPointer(0);
    vtkUnsignedCharArray* validArray =
      vtkUnsignedCharArray::SafeDownCast(output->GetPointData()->GetArray("FirstScatterValid"));
    if (!validArray)
    {
      vtkNew<vtkUnsignedCharArray> created;
      created->SetName("FirstScatterValid");
      output->GetPointData()->AddArray(created);
      validArray = created;
    }
    validArray->SetNumberOfTuples(pixelCount);
    buffers.valid = validArray->GetPointer(0);
    // The previous environment, where this eye's last frame was lit by another one that is
    // still held (PreviousLightingChanged). The scene is copied only then.
    hv::SceneView previousLightingScene;
    const hv::SceneView* eyeScene = &scene;
    buffers.previousLight = nullptr;
    if (self->GetRenderPreviousLighting() && scene.model == hv::PathTraced &&
      internals->PreviousLightingChanged(state, scene))
    {
      previousLightingScene = scene;
      previousLightingScene.previousEnvironment = state.LastEnvironment;
      previousLightingScene.shadePreviousEnvironment = true;
      eyeScene = &previousLightingScene;
      buffers.previousLight =
        OutputArray(output, "PreviousLightingRadiance", 3, pixelCount)->GetPointer(0);
    }
    else
    {
      output->GetPointData()->RemoveArray("PreviousLightingRadiance");
    }
    output->GetPointData()->SetActiveScalars("Radiance");

    const int frames = state.AccumulatedFrames + 1;
    const float inverseFrames = 1.0f / static_cast<float>(frames);
    buffers.radianceSum = state.RadianceSum.data();
    buffers.sumStarts = state.AccumulatedFrames == 0;
    // Pixels whose rays cannot meet the occupied volume get an empty sample directly.
    int rectangle[4] = { 0, 0, view.width, view.height };
    if (!scene.environmentVisible)
    {
      hv::occupiedScreenRectangle(
        scene.volume, view, rectangle[0], rectangle[1], rectangle[2], rectangle[3]);
    }
    const int bandHeight = (view.height + bandsPerEye - 1) / bandsPerEye;
    for (int band = 0; band < bandsPerEye; ++band)
    {
      const int rowBegin = band * bandHeight;
      const int rowEnd = std::min(view.height, rowBegin + bandHeight);
      vtkSMPTools::For(rowBegin, rowEnd, 1,
        [&](vtkIdType begin, vtkIdType end)
        {
          RenderRows(*eyeScene, view, rectangle, begin, end, static_cast<std::uint32_t>(eyeIndex),
            frameIndex, seed, samplesPerPixel, inverseFrames, buffers);
        });
      self->UpdateProgress((e + (band + 1.0) / bandsPerEye) / eyeCount);
    }
    state.AccumulatedFrames = frames;
    state.View = view.view;
    state.Projection = view.projection;
    state.SceneKey = internals->SceneKey;
    state.Settings = settings;
    state.Valid = true;
    state.LastEnvironment = scene.environment;
    // Only radiance lookups are made under a previous environment; its sampling tables are not
    // kept alive.
    state.LastEnvironment.distribution = hv::Distribution2DView();
    state.LastEnvironmentGeneration = internals->EnvironmentGeneration;
    std::copy_n(scene.lights, scene.lightCount, state.LastLights);
    state.LastLightCount = scene.lightCount;

    output->GetFieldData()->Initialize();
    SetFieldMatrix(output, "ViewMatrix", view.view);
    SetFieldMatrix(output, "ProjectionMatrix", view.projection);
    SetFieldInt(output, "FrameIndex", static_cast<int>(frameIndex));
    SetFieldInt(output, "AccumulatedFrames", frames);
    SetFieldInt(output, "Eye", eyeIndex);
    SetFieldInt(output, "ClassificationStamp", internals->ClassificationStamp);
    SetFieldInt(output, "DataStamp", internals->DataStamp);
    SetFieldMatrix(output, "VolumeMatrix", internals->VolumeMatrix);
    output->Modified();
  }
  self->InvokeEvent(vtkCommand::EndEvent);
}

namespace
{
bool CheckMatrices(vtkPathTracedVolumeMapper* self, vtkMatrix4x4* view, vtkMatrix4x4* projection,
  int width, int height)
{
  if (!view || !projection)
  {
    vtkErrorWithObjectMacro(self, "Both a view and a projection matrix are needed for each eye.");
    return false;
  }
  if (width < 1 || height < 1)
  {
    vtkErrorWithObjectMacro(self,
      "The image size " << width << "x" << height
                        << " is empty; give a positive width and height.");
    return false;
  }
  vtkNew<vtkMatrix4x4> product;
  vtkMatrix4x4::Multiply4x4(projection, view, product);
  if (std::abs(product->Determinant()) < 1e-30)
  {
    vtkErrorWithObjectMacro(self,
      "The projection x view matrix is singular; pass OpenGL-convention view and "
      "projection matrices (e.g. from vtkCamera or the headset).");
    return false;
  }
  return true;
}

hv::EyeView MakeEyeView(vtkMatrix4x4* view, vtkMatrix4x4* projection, int width, int height)
{
  hv::EyeView eye;
  eye.view = ToGlm(view);
  eye.projection = ToGlm(projection);
  eye.width = width;
  eye.height = height;
  eye.update();
  return eye;
}
}

int vtkPathTracedVolumeMapper::RenderStereoFrame(vtkVolume* volume, vtkMatrix4x4* leftView,
  vtkMatrix4x4* leftProjection, vtkMatrix4x4* rightView, vtkMatrix4x4* rightProjection, int width,
  int height, vtkLightCollection* lights)
{
  if (!CheckMatrices(this, leftView, leftProjection, width, height) ||
    !CheckMatrices(this, rightView, rightProjection, width, height))
  {
    return 0;
  }
  hv::SceneView scene;
  if (!this->PrepareScene(volume, lights, scene))
  {
    return 0;
  }
  const int eyes[2] = { 0, 1 };
  const hv::EyeView views[2] = { MakeEyeView(leftView, leftProjection, width, height),
    MakeEyeView(rightView, rightProjection, width, height) };
  this->RenderEyes(scene, eyes, views, 2, this->FrameIndex++);
  return 1;
}

int vtkPathTracedVolumeMapper::RenderEye(vtkVolume* volume, int eye, vtkMatrix4x4* view,
  vtkMatrix4x4* projection, int width, int height, vtkLightCollection* lights)
{
  if (eye != 0 && eye != 1)
  {
    vtkErrorMacro("RenderEye: the eye must be 0 (left or mono) or 1 (right), not " << eye << ".");
    return 0;
  }
  if (!CheckMatrices(this, view, projection, width, height))
  {
    return 0;
  }
  hv::SceneView scene;
  if (!this->PrepareScene(volume, lights, scene))
  {
    return 0;
  }
  const hv::EyeView eyeView = MakeEyeView(view, projection, width, height);
  this->RenderEyes(scene, &eye, &eyeView, 1, this->FrameIndex++);
  return 1;
}

void vtkPathTracedVolumeMapper::Render(vtkRenderer* renderer, vtkVolume* volume)
{
  auto* window = vtkOpenGLRenderWindow::SafeDownCast(renderer->GetRenderWindow());
  if (!window)
  {
    vtkErrorMacro(
      "vtkPathTracedVolumeMapper draws into a vtkOpenGLRenderWindow; for other windows use "
      "RenderStereoFrame() and GetEyeOutput().");
    return;
  }
  int width, height, originX, originY;
  renderer->GetTiledSizeAndOrigin(&width, &height, &originX, &originY);
  if (width < 1 || height < 1)
  {
    return;
  }
  vtkCamera* camera = renderer->GetActiveCamera();
  double aspect = renderer->GetTiledAspectRatio();
  const bool stereo = window->GetStereoRender() != 0;
  if (stereo && window->GetStereoType() == VTK_STEREO_SPLITVIEWPORT_HORIZONTAL)
  {
    // Each eye gets half of the viewport, as vtkOpenGLCamera sets it up.
    width /= 2;
    aspect /= 2.0;
  }
  const int displayedEye = (stereo && !camera->GetLeftEye()) ? 1 : 0;

  // Each stereo pass renders the eye VTK has set the camera up for (vtkCamera applies the
  // eye offset), so every stereo mode of vtkRenderWindow works; both eyes share a frame index,
  // which advances after the right eye.
  auto& internals = *this->Internals;
  hv::SceneView scene;
  if (!this->PrepareScene(volume, renderer->GetLights(), scene))
  {
    return;
  }
  vtkImageData* image = nullptr;
  const bool bothEyes = stereo && window->GetStereoType() != VTK_STEREO_LEFT &&
    window->GetStereoType() != VTK_STEREO_RIGHT;
  if (this->Denoiser)
  {
    image = this->RenderDenoisedWindowEye(
      scene, camera, displayedEye, bothEyes, width, height, aspect);
  }
  else
  {
    vtkNew<vtkMatrix4x4> view;
    vtkNew<vtkMatrix4x4> projection;
    view->DeepCopy(camera->GetModelViewTransformMatrix());
    projection->DeepCopy(camera->GetProjectionTransformMatrix(aspect, -1, 1));
    const hv::EyeView eyeView = MakeEyeView(view, projection, width, height);
    const bool lastPassOfFrame = !bothEyes || displayedEye == 1;
    this->RenderEyes(scene, &displayedEye, &eyeView, 1, this->FrameIndex);
    if (lastPassOfFrame)
    {
      ++this->FrameIndex;
    }
    image = internals.Eyes[displayedEye].Output;
  }
  if (!image)
  {
    return;
  }
  int dims[3];
  image->GetDimensions(dims);
  internals.DisplayPixels.resize(4 * static_cast<std::size_t>(dims[0]) * dims[1]);
  if (!this->ToneMapImage(image, internals.DisplayPixels.data()))
  {
    return;
  }
  unsigned char* target = internals.DisplayPixels.data();

  if (!internals.Texture)
  {
    internals.Texture = vtkTextureObject::New();
  }
  internals.Texture->SetContext(window);
  internals.Texture->SetMinificationFilter(vtkTextureObject::Nearest);
  internals.Texture->SetMagnificationFilter(vtkTextureObject::Nearest);
  internals.Texture->SetWrapS(vtkTextureObject::ClampToEdge);
  internals.Texture->SetWrapT(vtkTextureObject::ClampToEdge);
  internals.Texture->Create2DFromRaw(dims[0], dims[1], 4, VTK_UNSIGNED_CHAR, target);

  if (!internals.Quad)
  {
    std::string fragment = vtkOpenGLRenderUtilities::GetFullScreenQuadFragmentShaderTemplate();
    vtkShaderProgram::Substitute(
      fragment, "//VTK::FSQ::Decl", "uniform sampler2D radianceTexture;\n");
    vtkShaderProgram::Substitute(
      fragment, "//VTK::FSQ::Impl", "  gl_FragData[0] = texture(radianceTexture, texCoord);\n");
    internals.Quad = new vtkOpenGLQuadHelper(window, nullptr, fragment.c_str(), nullptr);
  }
  else
  {
    window->GetShaderCache()->ReadyShaderProgram(internals.Quad->Program);
  }
  if (!internals.Quad->Program || !internals.Quad->Program->GetCompiled())
  {
    vtkErrorMacro("The display shader did not compile; the OpenGL context may lack OpenGL 3.2.");
    return;
  }
  vtkOpenGLState* state = window->GetState();
  vtkOpenGLState::ScopedglEnableDisable blendSaver(state, GL_BLEND);
  vtkOpenGLState::ScopedglEnableDisable depthSaver(state, GL_DEPTH_TEST);
  vtkOpenGLState::ScopedglBlendFuncSeparate blendFunctionSaver(state);
  vtkOpenGLState::ScopedglDepthMask depthMaskSaver(state);
  state->vtkglEnable(GL_BLEND);
  state->vtkglBlendFuncSeparate(GL_ONE, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  state->vtkglDisable(GL_DEPTH_TEST);
  state->vtkglDepthMask(GL_FALSE);
  internals.Texture->Activate();
  internals.Quad->Program->SetUniformi("radianceTexture", internals.Texture->GetTextureUnit());
  internals.Quad->Render();
  internals.Texture->Deactivate();
}

// A window frame with the denoiser attached. Mono: render, denoise, show. Stereo: the first
// pass renders both eyes with the camera's matrices for each (vtkCamera switches eyes by
// LeftEye) and denoises them together; the second pass shows the other denoised eye unless
// the camera moved in between.
vtkImageData* vtkPathTracedVolumeMapper::RenderDenoisedWindowEye(const hv::SceneView& scene,
  vtkCamera* camera, int displayedEye, bool stereo, int width, int height, double aspect)
{
  vtkInternals& internals = *this->Internals;
  auto eyeViewOf = [&](vtkCamera* c)
  {
    vtkNew<vtkMatrix4x4> view;
    vtkNew<vtkMatrix4x4> projection;
    view->DeepCopy(c->GetModelViewTransformMatrix());
    projection->DeepCopy(c->GetProjectionTransformMatrix(aspect, -1, 1));
    return MakeEyeView(view, projection, width, height);
  };
  const hv::EyeView current = eyeViewOf(camera);
  if (!stereo)
  {
    this->RenderEyes(scene, &displayedEye, &current, 1, this->FrameIndex++);
    this->Denoiser->SetInputData(0, internals.Eyes[displayedEye].Output);
    this->Denoiser->SetInputData(1, nullptr);
    this->Denoiser->Update();
    return this->Denoiser->GetEyeOutput(0);
  }
  if (displayedEye == 1 && internals.DenoisedRightReady &&
    internals.DenoisedRightView == current.view &&
    internals.DenoisedRightProjection == current.projection)
  {
    internals.DenoisedRightReady = false;
    return this->Denoiser->GetEyeOutput(1);
  }
  const int leftEye = camera->GetLeftEye();
  camera->SetLeftEye(displayedEye == 1 ? 1 : 0);
  const hv::EyeView other = eyeViewOf(camera);
  camera->SetLeftEye(leftEye);
  const int eyes[2] = { 0, 1 };
  const hv::EyeView views[2] = { displayedEye == 0 ? current : other,
    displayedEye == 0 ? other : current };
  this->RenderEyes(scene, eyes, views, 2, this->FrameIndex++);
  this->Denoiser->SetInputData(0, internals.Eyes[0].Output);
  this->Denoiser->SetInputData(1, internals.Eyes[1].Output);
  this->Denoiser->Update();
  internals.DenoisedRightView = views[1].view;
  internals.DenoisedRightProjection = views[1].projection;
  internals.DenoisedRightReady = displayedEye == 0;
  return this->Denoiser->GetEyeOutput(displayedEye);
}

bool vtkPathTracedVolumeMapper::ToneMapImage(vtkImageData* image, unsigned char* target)
{
  vtkFloatArray* radiance =
    vtkFloatArray::SafeDownCast(image->GetPointData()->GetArray("Radiance"));
  if (!radiance || radiance->GetNumberOfTuples() == 0)
  {
    return false;
  }
  // Un-premultiply, exposure, operator, sRGB, premultiply again: the quad is blended as
  // premultiplied colour.
  const float exposure = static_cast<float>(std::pow(2.0, this->Exposure));
  const int toneOperator =
    this->ToneMapping == TONE_MAPPING_ACES ? hv::ToneMapACES : hv::ToneMapClamp;
  const float* source = radiance->GetPointer(0);
  vtkSMPTools::For(0, radiance->GetNumberOfTuples(),
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType i = begin; i < end; ++i)
      {
        hv::toneMapPixel(source + 4 * i, exposure, toneOperator, target + 4 * i);
      }
    });
  return true;
}

int vtkPathTracedVolumeMapper::ComputeDisplayImage(int eye, vtkImageData* output)
{
  if ((eye != 0 && eye != 1) || !output)
  {
    vtkErrorMacro("ComputeDisplayImage needs eye 0 or 1 and an output vtkImageData.");
    return 0;
  }
  if (!vtkFloatArray::SafeDownCast(
        this->Internals->Eyes[eye].Output->GetPointData()->GetArray("Radiance")))
  {
    vtkErrorMacro("Eye " << eye << " has not been rendered yet; render a frame first.");
    return 0;
  }
  return this->ComputeDisplayImage(this->Internals->Eyes[eye].Output, output);
}

int vtkPathTracedVolumeMapper::ComputeDisplayImage(vtkImageData* radianceImage, vtkImageData* output)
{
  if (!radianceImage || !output || radianceImage == output)
  {
    vtkErrorMacro("ComputeDisplayImage needs an image with a \"Radiance\" array and a separate "
                  "output vtkImageData.");
    return 0;
  }
  int dims[3];
  radianceImage->GetDimensions(dims);
  vtkNew<vtkUnsignedCharArray> pixels;
  pixels->SetName("DisplayRGBA");
  pixels->SetNumberOfComponents(4);
  pixels->SetNumberOfTuples(static_cast<vtkIdType>(dims[0]) * dims[1]);
  if (!this->ToneMapImage(radianceImage, pixels->GetPointer(0)))
  {
    vtkErrorMacro("The image has no float RGBA \"Radiance\" array to tone-map; pass an eye "
                  "image of this mapper or a denoiser's output.");
    return 0;
  }
  output->Initialize();
  output->SetDimensions(dims[0], dims[1], 1);
  output->GetPointData()->SetScalars(pixels);
  return 1;
}

void vtkPathTracedVolumeMapper::ReleaseGraphicsResources(vtkWindow* window)
{
  if (this->Internals->Quad)
  {
    this->Internals->Quad->ReleaseGraphicsResources(window);
    delete this->Internals->Quad;
    this->Internals->Quad = nullptr;
  }
  if (this->Internals->Texture)
  {
    this->Internals->Texture->ReleaseGraphicsResources(window);
  }
  this->Superclass::ReleaseGraphicsResources(window);
}

void vtkPathTracedVolumeMapper::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "IlluminationModel: " << this->GetIlluminationModelAsString() << "\n";
  os << indent << "SamplesPerPixel: " << this->SamplesPerPixel << "\n";
  os << indent << "MaximumBounces: " << this->MaximumBounces << "\n";
  os << indent << "RussianRouletteStartBounce: " << this->RussianRouletteStartBounce << "\n";
  os << indent << "SecondaryRayRoulette: " << this->SecondaryRayRoulette << "\n";
  os << indent << "Anisotropy: " << this->Anisotropy << "\n";
  os << indent << "DensityScale: " << this->DensityScale << "\n";
  os << indent << "SurfaceScatteringFactor: " << this->SurfaceScatteringFactor << "\n";
  os << indent << "Seed: " << this->Seed << "\n";
  os << indent << "StratifiedSubpixelSamples: " << (this->StratifiedSubpixelSamples ? "On" : "Off")
     << "\n";
  os << indent << "ProgressiveAccumulation: " << (this->ProgressiveAccumulation ? "On" : "Off")
     << "\n";
  os << indent << "FrameIndex: " << this->FrameIndex << "\n";
  os << indent << "EnvironmentMap: "
     << (this->GetNumberOfInputConnections(1) ? "connected" : "none (uniform)") << "\n";
  os << indent << "EnvironmentToWorldMatrix:\n";
  this->EnvironmentToWorldMatrix->PrintSelf(os, indent.GetNextIndent());
  os << indent << "EnvironmentRadiance: (" << this->EnvironmentRadiance[0] << ", "
     << this->EnvironmentRadiance[1] << ", " << this->EnvironmentRadiance[2] << ")\n";
  os << indent << "EnvironmentIntensity: " << this->EnvironmentIntensity << "\n";
  os << indent << "RenderPreviousLighting: " << (this->RenderPreviousLighting ? "On" : "Off")
     << "\n";
  os << indent << "EnvironmentVisible: " << (this->EnvironmentVisible ? "On" : "Off") << "\n";
  os << indent
     << "EnvironmentImportanceSampling: " << (this->EnvironmentImportanceSampling ? "On" : "Off")
     << "\n";
  os << indent << "UseRendererLights: " << (this->UseRendererLights ? "On" : "Off") << "\n";
  os << indent << "StepLengthFactor: " << this->StepLengthFactor << "\n";
  os << indent << "MacrocellSize: " << this->MacrocellSize << "\n";
  os << indent << "Exposure: " << this->Exposure << "\n";
  os << indent << "ToneMapping: " << (this->ToneMapping == TONE_MAPPING_ACES ? "ACES" : "Clamp")
     << "\n";
  os << indent << "Denoiser: " << static_cast<void*>(this->Denoiser) << "\n";
}
