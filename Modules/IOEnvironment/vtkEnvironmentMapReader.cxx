// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "vtkEnvironmentMapReader.h"

#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkStreamingDemandDrivenPipeline.h"

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <memory>
#include <vector>

vtkStandardNewMacro(vtkEnvironmentMapReader);

vtkEnvironmentMapReader::vtkEnvironmentMapReader()
{
  this->SetNumberOfInputPorts(0);
}

vtkEnvironmentMapReader::~vtkEnvironmentMapReader()
{
  this->SetFileName(nullptr);
}

namespace
{
std::unique_ptr<OIIO::ImageInput> OpenImage(vtkEnvironmentMapReader* self, const char* fileName)
{
  if (!fileName || !*fileName)
  {
    vtkErrorWithObjectMacro(
      self, "No file name: call SetFileName() with an .exr or .hdr panorama.");
    return nullptr;
  }
  auto image = OIIO::ImageInput::open(fileName);
  if (!image)
  {
    vtkErrorWithObjectMacro(self,
      "Cannot open environment map '" << fileName << "': " << OIIO::geterror()
                                      << ". Check the path and that it is an "
                                         "image OpenImageIO reads (EXR, HDR, ...).");
  }
  return image;
}
}

int vtkEnvironmentMapReader::RequestInformation(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  auto image = OpenImage(this, this->FileName);
  if (!image)
  {
    return 0;
  }
  const OIIO::ImageSpec& spec = image->spec();
  int extent[6] = { 0, spec.width - 1, 0, spec.height - 1, 0, 0 };
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent, 6);
  vtkDataObject::SetPointDataActiveScalarInfo(outInfo, VTK_FLOAT, 3);
  return 1;
}

int vtkEnvironmentMapReader::RequestData(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkImageData* output = vtkImageData::GetData(outputVector);
  auto image = OpenImage(this, this->FileName);
  if (!image)
  {
    return 0;
  }
  const OIIO::ImageSpec& spec = image->spec();
  const int width = spec.width;
  const int height = spec.height;
  const int channels = spec.nchannels;
  std::vector<float> pixels(static_cast<std::size_t>(width) * height * channels);
  if (!image->read_image(0, 0, 0, channels, OIIO::TypeDesc::FLOAT, pixels.data()))
  {
    vtkErrorMacro("Reading '" << this->FileName << "' failed: " << image->geterror());
    return 0;
  }
  image->close();

  output->SetDimensions(width, height, 1);
  vtkNew<vtkFloatArray> radiance;
  radiance->SetName("Radiance");
  radiance->SetNumberOfComponents(3);
  radiance->SetNumberOfTuples(static_cast<vtkIdType>(width) * height);
  float* target = radiance->GetPointer(0);
  this->NumberOfInvalidValues = 0;
  this->NumberOfClampedNegativeValues = 0;
  for (int row = 0; row < height; ++row)
  {
    // Image files start at the top row; VTK images at the bottom one.
    const float* source =
      pixels.data() + static_cast<std::size_t>(height - 1 - row) * width * channels;
    for (int column = 0; column < width; ++column)
    {
      for (int c = 0; c < 3; ++c)
      {
        float value = source[column * channels + (channels >= 3 ? c : 0)];
        if (!std::isfinite(value))
        {
          ++this->NumberOfInvalidValues;
          value = this->ReplaceNonFiniteValues ? 0.0f : value;
        }
        else if (value < 0.0f)
        {
          // Lossy EXR compression (DWAA/DWAB, B44) undershoots to about -1e-3 near black;
          // radiance cannot be negative.
          ++this->NumberOfClampedNegativeValues;
          value = 0.0f;
        }
        target[3 * (static_cast<std::size_t>(row) * width + column) + c] = value;
      }
    }
  }
  output->GetPointData()->SetScalars(radiance);
  if (this->NumberOfInvalidValues > 0 && !this->ReplaceNonFiniteValues)
  {
    vtkErrorMacro("'" << this->FileName << "' has " << this->NumberOfInvalidValues
                      << " NaN or infinite values; turn ReplaceNonFiniteValues on to set them to "
                         "zero, or repair the file.");
    return 0;
  }
  if (width != 2 * height)
  {
    vtkWarningMacro("'" << this->FileName << "' is " << width << "x" << height
                        << "; an equirectangular environment map should be twice as wide as high.");
  }
  return 1;
}

void vtkEnvironmentMapReader::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << (this->FileName ? this->FileName : "(none)") << "\n";
  os << indent << "ReplaceNonFiniteValues: " << (this->ReplaceNonFiniteValues ? "On" : "Off")
     << "\n";
  os << indent << "NumberOfInvalidValues: " << this->NumberOfInvalidValues << "\n";
  os << indent << "NumberOfClampedNegativeValues: " << this->NumberOfClampedNegativeValues << "\n";
}
