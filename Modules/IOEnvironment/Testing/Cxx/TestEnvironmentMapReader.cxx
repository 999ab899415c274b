// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// vtkEnvironmentMapReader: reads EXR radiance into VTK's row order, clamps the negative
// undershoot of lossy compression, rejects NaN/Inf unless asked to replace them, reports a
// missing file, and reads the real blender-data panoramas when they are installed.
#include "vtkEnvironmentMapReader.h"

#include "vtkDataArray.h"
#include "vtkExecutive.h"
#include "vtkImageData.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkTestErrorObserver.h"

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>
#include <string>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

namespace
{
int failures = 0;

void Expect(bool condition, const std::string& what)
{
  if (!condition)
  {
    std::cerr << "FAILED: " << what << "\n";
    ++failures;
  }
}

// A 16x8 RGB map whose texel (x, row) from the top has R = x, G = row, B = 1, with one
// negative and optionally one NaN texel.
std::string WriteMap(const std::string& name, bool withNaN)
{
  const int width = 16, height = 8;
  std::vector<float> pixels(width * height * 3);
  for (int row = 0; row < height; ++row)
  {
    for (int x = 0; x < width; ++x)
    {
      float* p = &pixels[3 * (row * width + x)];
      p[0] = static_cast<float>(x);
      p[1] = static_cast<float>(row);
      p[2] = 1.0f;
    }
  }
  pixels[3 * 5 + 2] = -0.002f;
  if (withNaN)
  {
    pixels[3 * 7 + 1] = std::numeric_limits<float>::quiet_NaN();
  }
  const std::string path =
    "/tmp/holovolume-reader-test-" + std::to_string(getpid()) + "-" + name + ".exr";
  auto out = OIIO::ImageOutput::create(path);
  OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::FLOAT);
  out->open(path, spec);
  out->write_image(OIIO::TypeDesc::FLOAT, pixels.data());
  out->close();
  return path;
}
}

int TestEnvironmentMapReader(int, char*[])
{
  {
    const std::string path = WriteMap("valid", false);
    vtkNew<vtkEnvironmentMapReader> reader;
    reader->SetFileName(path.c_str());
    reader->Update();
    vtkImageData* image = reader->GetOutput();
    int dims[3];
    image->GetDimensions(dims);
    Expect(dims[0] == 16 && dims[1] == 8 && dims[2] == 1, "dimensions 16x8x1");
    vtkDataArray* radiance = image->GetPointData()->GetScalars();
    Expect(radiance && radiance->GetNumberOfComponents() == 3, "three-component radiance");
    if (radiance)
    {
      // VTK row j = 0 is the file's bottom row (row 7 from the top).
      Expect(radiance->GetComponent(0 * 16 + 3, 0) == 3.0 &&
          radiance->GetComponent(0 * 16 + 3, 1) == 7.0,
        "bottom VTK row holds the file's last row");
      Expect(radiance->GetComponent(7 * 16 + 5, 2) == 0.0, "a negative texel is clamped to zero");
    }
    Expect(reader->GetNumberOfClampedNegativeValues() == 1, "one clamped negative value counted");
    Expect(reader->GetNumberOfInvalidValues() == 0, "no invalid values");
    std::remove(path.c_str());
  }
  {
    const std::string path = WriteMap("nan", true);
    vtkNew<vtkEnvironmentMapReader> reader;
    reader->SetFileName(path.c_str());
    vtkNew<vtkTest::ErrorObserver> observer;
    reader->AddObserver(vtkCommand::ErrorEvent, observer);
    reader->GetExecutive()->AddObserver(vtkCommand::ErrorEvent, observer);
    reader->Update();
    Expect(observer->GetError() &&
        observer->GetErrorMessage().find("ReplaceNonFiniteValues") != std::string::npos,
      "a NaN texel is an error that names ReplaceNonFiniteValues");
    reader->ReplaceNonFiniteValuesOn();
    reader->Modified();
    observer->Clear();
    reader->Update();
    Expect(!observer->GetError(), "with ReplaceNonFiniteValues the NaN map reads");
    Expect(reader->GetNumberOfInvalidValues() == 1, "one invalid value counted");
    vtkDataArray* radiance = reader->GetOutput()->GetPointData()->GetScalars();
    Expect(radiance && radiance->GetComponent(7 * 16 + 7, 1) == 0.0, "the NaN texel became zero");
    std::remove(path.c_str());
  }
  {
    vtkNew<vtkEnvironmentMapReader> reader;
    reader->SetFileName("/nonexistent/sky.exr");
    vtkNew<vtkTest::ErrorObserver> observer;
    reader->AddObserver(vtkCommand::ErrorEvent, observer);
    reader->GetExecutive()->AddObserver(vtkCommand::ErrorEvent, observer);
    reader->Update();
    Expect(observer->GetError() &&
        observer->GetErrorMessage().find("Check the path") != std::string::npos,
      "a missing file says to check the path");
  }
  {
    const char* real = "/usr/share/blender/datafiles/studiolights/world/sunrise.exr";
    struct stat info;
    if (stat(real, &info) == 0)
    {
      vtkNew<vtkEnvironmentMapReader> reader;
      reader->SetFileName(real);
      reader->Update();
      int dims[3];
      reader->GetOutput()->GetDimensions(dims);
      double range[2];
      reader->GetOutput()->GetPointData()->GetScalars()->GetRange(range, 0);
      std::cout << real << ": " << dims[0] << "x" << dims[1] << ", red " << range[0] << " .. "
                << range[1] << ", " << reader->GetNumberOfClampedNegativeValues()
                << " negative values clamped\n";
      Expect(dims[0] == 2 * dims[1] && dims[1] >= 256, "a real panorama is equirectangular");
      Expect(
        range[0] >= 0.0 && range[1] > 1000.0, "the real sunrise has a sun far brighter than 1");
    }
    else
    {
      std::cout << "blender-data is not installed; skipped the real panorama\n";
    }
  }
  return failures == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
