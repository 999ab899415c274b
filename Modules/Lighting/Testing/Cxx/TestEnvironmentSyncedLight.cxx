// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// vtkEnvironmentSyncedLight in a pipeline: a clipped LDR panorama with a lamp becomes an HDR
// radiance map in world orientation, the lamp is found in the right world direction, T reacts
// to a lamp switching on and not to a repeated frame or a new pose, HDR input bypasses the
// estimation, and bad input is reported without a crash.
#include "vtkEnvironmentSyncedLight.h"

#include "LightingTestUtilities.h"

#include "vtkCommand.h"
#include "vtkDataArray.h"
#include "vtkExecutive.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkMatrix4x4.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkPolyData.h"
#include "vtkSmartPointer.h"
#include "vtkStringArray.h"
#include "vtkTrivialProducer.h"
#include "vtkUnsignedCharArray.h"

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>
#include <string>

namespace
{
constexpr double Pi = 3.14159265358979323846;

// Direction of the texel centre (i, j) of a panorama in VTK row order (j = 0 at the nadir),
// in the hv/Equirectangular.h parameterisation.
void TexelDirection(int i, int j, int width, int height, double d[3])
{
  const double phi = ((i + 0.5) / width - 0.5) * 2.0 * Pi;
  const double theta = (1.0 - (j + 0.5) / height) * Pi;
  d[0] = std::sin(theta) * std::sin(phi);
  d[1] = std::cos(theta);
  d[2] = -std::sin(theta) * std::cos(phi);
}

// An 8-bit sRGB panorama of a grey room (linear 0.2 above the horizon, 0.1 below) with lamps:
// disks of the given radius at 1000 x the background, filmed through the lens's PSF (the
// glare halo the estimator reads the lamp's radiance from) and clipped.
struct Lamp
{
  double Direction[3];
  double RadiusDegrees;
};

vtkSmartPointer<vtkImageData> MakeLdrPanorama(int width, const Lamp* lamps, int lampCount)
{
  const int height = width / 2;
  cv::Mat linear(height, width, CV_32FC3);
  for (int row = 0; row < height; ++row)
  {
    for (int i = 0; i < width; ++i)
    {
      double d[3];
      TexelDirection(i, height - 1 - row, width, height, d);
      cv::Vec3f value = d[1] < 0.0 ? cv::Vec3f(0.1f, 0.09f, 0.08f) : cv::Vec3f(0.2f, 0.19f, 0.17f);
      for (int k = 0; k < lampCount; ++k)
      {
        const Lamp& lamp = lamps[k];
        const double n = std::sqrt(lamp.Direction[0] * lamp.Direction[0] +
          lamp.Direction[1] * lamp.Direction[1] + lamp.Direction[2] * lamp.Direction[2]);
        const double c =
          (d[0] * lamp.Direction[0] + d[1] * lamp.Direction[1] + d[2] * lamp.Direction[2]) / n;
        if (c >= std::cos(lamp.RadiusDegrees * Pi / 180.0))
        {
          value = cv::Vec3f(200.0f, 200.0f, 200.0f);
        }
      }
      linear.at<cv::Vec3f>(row, i) = value;
    }
  }
  return lightingtest::FilmLdrPanorama(linear);
}

struct ErrorCounter : public vtkCommand
{
  static ErrorCounter* New() { return new ErrorCounter; }
  void Execute(vtkObject*, unsigned long event, void* message) override
  {
    if (event == vtkCommand::ErrorEvent)
    {
      ++this->Errors;
      this->LastMessage = static_cast<const char*>(message);
    }
    else
    {
      ++this->Warnings;
    }
  }
  int Errors = 0;
  int Warnings = 0;
  std::string LastMessage;
};

double AngleDegrees(const double a[3], const double b[3])
{
  const double na = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
  const double nb = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
  const double c = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (na * nb);
  return std::acos(std::max(-1.0, std::min(1.0, c))) * 180.0 / Pi;
}

double FieldValue(vtkImageData* image, const char* name)
{
  vtkDataArray* array = image->GetFieldData()->GetArray(name);
  return array ? array->GetComponent(0, 0) : std::numeric_limits<double>::quiet_NaN();
}
}

int TestEnvironmentSyncedLight(int, char*[])
{
  int failures = 0;
  auto expect = [&](bool condition, const std::string& what)
  {
    if (!condition)
    {
      std::cerr << "FAILED: " << what << "\n";
      ++failures;
    }
  };

  // A lamp 40 degrees above the horizon, in front of the camera (camera frame).
  const Lamp lamp = { { 0.0, std::sin(40.0 * Pi / 180.0), -std::cos(40.0 * Pi / 180.0) }, 10.0 };
  vtkNew<vtkTrivialProducer> producer;
  producer->SetOutput(MakeLdrPanorama(256, &lamp, 1));

  vtkNew<vtkEnvironmentSyncedLight> synced;
  synced->SetInputConnection(producer->GetOutputPort());
  synced->SetOutputHeight(128);
  // The headset has turned 90 degrees to the left (about +Y): the lamp, in front of the
  // camera, is to the world's -X.
  vtkNew<vtkMatrix4x4> pose;
  pose->SetElement(0, 0, 0.0);
  pose->SetElement(0, 2, 1.0);
  pose->SetElement(2, 0, -1.0);
  pose->SetElement(2, 2, 0.0);
  synced->SetHeadsetPose(pose);
  synced->SetProxyRadius(1e6); // far walls: a pure rotation
  synced->Update();

  vtkImageData* q = synced->GetOutput();
  int dims[3];
  q->GetDimensions(dims);
  expect(dims[0] == 256 && dims[1] == 128 && dims[2] == 1, "Q is 256 x 128");
  auto* radiance = vtkFloatArray::SafeDownCast(q->GetPointData()->GetArray("Radiance"));
  expect(radiance && radiance->GetNumberOfComponents() == 3, "Q has a float RGB Radiance array");
  if (!radiance || failures)
  {
    return EXIT_FAILURE;
  }
  double range[2];
  radiance->GetRange(range, 1);
  std::cout << "Q green range " << range[0] << " .. " << range[1] << "\n";
  // The LDR input clips at 1; the lamp's true radiance is 200.
  expect(range[1] > 20.0, "the lamp's radiance is recovered far above the clip level");

  vtkPolyData* lights = synced->GetDetectedLights();
  expect(lights->GetNumberOfPoints() >= 1, "the lamp is detected");
  if (lights->GetNumberOfPoints() >= 1)
  {
    double direction[3];
    lights->GetPointData()->GetArray("Direction")->GetTuple(0, direction);
    const double expected[3] = { lamp.Direction[2], lamp.Direction[1], -lamp.Direction[0] };
    const double error = AngleDegrees(direction, expected);
    std::cout << "lamp direction error " << error << " degrees, intensity "
              << lights->GetPointData()->GetArray("Intensity")->GetComponent(0, 0) << "\n";
    expect(error < 2.0, "the lamp is found in its world direction within 2 degrees");
    // The point sits on the unit sphere around the volume centre.
    double point[3];
    lights->GetPoint(0, point);
    expect(AngleDegrees(point, expected) < 2.0, "the light's point lies in its direction");
  }
  expect(FieldValue(q, "IlluminationDifference") > 0.99, "the first frame has T close to 1");
  // The producer gives no "FrameIndex": the output counts the distinct input frames instead, so
  // that the denoiser can tell a new camera frame from a re-execution with the same one.
  const double firstIndex = FieldValue(q, "FrameIndex");

  // Same input again: no re-execution.
  const vtkMTimeType outputTime = q->GetMTime();
  synced->Update();
  expect(synced->GetOutput()->GetMTime() == outputTime, "no re-execution without changes");

  // The same camera frame again (re-sent by the source): T about 0.
  producer->GetOutputDataObject(0)->Modified();
  producer->Modified();
  synced->Update();
  const double repeatT = synced->GetIlluminationDifference();
  std::cout << "T repeated frame " << repeatT << "\n";
  expect(repeatT < 0.05, "a repeated frame gives T < 0.05");
  const double repeatIndex = FieldValue(synced->GetOutput(), "FrameIndex");
  expect(repeatIndex == firstIndex + 1.0,
    "a new input frame without a FrameIndex of its own gets the next index");

  // A new pose with the same frame: re-executes, T is kept.
  pose->SetElement(0, 3, 0.3);
  synced->SetHeadsetPose(pose);
  synced->Update();
  expect(synced->GetOutput()->GetMTime() != outputTime, "a new pose re-executes");
  expect(std::fabs(synced->GetIlluminationDifference() - repeatT) < 1e-6,
    "a new pose is not a lighting change");
  expect(FieldValue(synced->GetOutput(), "FrameIndex") == repeatIndex,
    "a new pose with the same input frame keeps its index");

  // A second lamp switches on behind the camera: T rises above 0.5 with the least similar
  // patch (the paper's text), but not with the most similar patch (Eq. 1 as printed).
  const Lamp lamps[2] = { lamp, { { 0.3, 0.2, 1.0 }, 8.0 } };
  producer->SetOutput(MakeLdrPanorama(256, lamps, 2));
  synced->Update();
  const double switchT = synced->GetIlluminationDifference();
  std::cout << "T lamp on " << switchT << "\n";
  expect(switchT > 0.5, "a lamp switching on gives T > 0.5");
  expect(FieldValue(synced->GetOutput(), "FrameIndex") == repeatIndex + 1.0,
    "the lamp's frame gets the next index");
  expect(FieldValue(synced->GetOutput(), "IlluminationDifference") == switchT,
    "T travels in the field data");
  auto* similarity = synced->GetOutput()->GetFieldData()->GetArray("PatchSimilarity");
  expect(
    similarity && similarity->GetNumberOfTuples() == 8 && similarity->GetNumberOfComponents() == 8,
    "8 x 8 patch similarities travel in the field data");

  synced->SetIlluminationDifferenceModeToMostSimilarPatch();
  synced->ResetHistory();
  producer->SetOutput(MakeLdrPanorama(256, &lamp, 1));
  synced->Update();
  producer->SetOutput(MakeLdrPanorama(256, lamps, 2));
  synced->Update();
  std::cout << "T lamp on, Eq. 1 as printed " << synced->GetIlluminationDifference() << "\n";
  expect(synced->GetIlluminationDifference() < 0.1,
    "Eq. 1 as printed barely notices one patch changing");
  synced->SetIlluminationDifferenceModeToLeastSimilarPatch();

  // HDR input bypasses the estimation: the radiance passes through.
  {
    auto hdr = vtkSmartPointer<vtkImageData>::New();
    hdr->SetDimensions(128, 64, 1);
    hdr->AllocateScalars(VTK_FLOAT, 3);
    auto* values = static_cast<float*>(hdr->GetScalarPointer());
    std::fill(values, values + 128 * 64 * 3, 0.5f);
    values[3 * (40 * 128 + 70) + 1] = 5000.0f; // one very bright texel
    vtkNew<vtkStringArray> encoding;
    encoding->SetName("Encoding");
    encoding->InsertNextValue("SceneLinear");
    hdr->GetFieldData()->AddArray(encoding);
    vtkNew<vtkEnvironmentSyncedLight> passThrough;
    passThrough->SetInputData(hdr);
    passThrough->SetOutputHeight(0);
    passThrough->TemporalSmoothingOff();
    passThrough->Update();
    auto* out =
      vtkFloatArray::SafeDownCast(passThrough->GetOutput()->GetPointData()->GetArray("Radiance"));
    double hdrRange[2];
    out->GetRange(hdrRange, 1);
    expect(std::fabs(hdrRange[0] - 0.5) < 1e-5 && std::fabs(hdrRange[1] - 5000.0) < 1e-2,
      "HDR input passes through unchanged (identity pose)");
  }

  // Bad input: an error that says what to do, no crash.
  {
    vtkNew<ErrorCounter> errors;
    vtkNew<vtkEnvironmentSyncedLight> bad;
    bad->AddObserver(vtkCommand::ErrorEvent, errors);
    bad->AddObserver(vtkCommand::WarningEvent, errors);
    // The executive's own "returned failure" report, kept apart from the filter's message.
    vtkNew<ErrorCounter> executiveErrors;
    bad->GetExecutive()->AddObserver(vtkCommand::ErrorEvent, executiveErrors);

    auto wrongAspect = vtkSmartPointer<vtkImageData>::New();
    wrongAspect->SetDimensions(100, 100, 1);
    wrongAspect->AllocateScalars(VTK_UNSIGNED_CHAR, 3);
    bad->SetInputData(wrongAspect);
    bad->Update();
    expect(
      errors->Errors >= 1 && errors->LastMessage.find("width = 2 x height") != std::string::npos,
      "a square image is rejected with a hint");

    auto doubles = vtkSmartPointer<vtkImageData>::New();
    doubles->SetDimensions(64, 32, 1);
    doubles->AllocateScalars(VTK_DOUBLE, 3);
    const int before = errors->Errors;
    bad->SetInputData(doubles);
    bad->Update();
    expect(errors->Errors > before && errors->LastMessage.find("vtkImageCast") != std::string::npos,
      "double scalars are rejected with a hint");

    auto nan = vtkSmartPointer<vtkImageData>::New();
    nan->SetDimensions(64, 32, 1);
    nan->AllocateScalars(VTK_FLOAT, 3);
    auto* nanValues = static_cast<float*>(nan->GetScalarPointer());
    std::fill(nanValues, nanValues + 64 * 32 * 3, 1.0f);
    nanValues[100] = std::numeric_limits<float>::quiet_NaN();
    const int beforeNan = errors->Errors;
    bad->SetInputData(nan);
    bad->Update();
    expect(errors->Errors > beforeNan && errors->LastMessage.find("NaN") != std::string::npos,
      "NaN radiance is rejected");

    auto grey = vtkSmartPointer<vtkImageData>::New();
    grey->SetDimensions(64, 32, 1);
    grey->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
    std::fill(static_cast<unsigned char*>(grey->GetScalarPointer()),
      static_cast<unsigned char*>(grey->GetScalarPointer()) + 64 * 32, 128);
    const int beforeGrey = errors->Errors;
    bad->SetInputData(grey);
    bad->SetOutputHeight(0);
    bad->Update();
    expect(errors->Errors == beforeGrey, "a grey panorama is accepted (used for R, G and B)");
    double greyRange[2];
    bad->GetOutput()->GetPointData()->GetScalars()->GetRange(greyRange, 0);
    // sRGB code 128 is linear 0.2158.
    expect(std::fabs(greyRange[0] - 0.2158) < 2e-3 && std::fabs(greyRange[1] - 0.2158) < 2e-3,
      "grey code 128 linearises to 0.216");

    vtkNew<vtkMatrix4x4> scaled;
    scaled->SetElement(0, 0, 2.0);
    bad->SetHeadsetPose(scaled);
    const int beforeScale = errors->Errors;
    bad->Update();
    expect(errors->Errors > beforeScale && errors->LastMessage.find("rigid") != std::string::npos,
      "a pose with scale is rejected");
  }

  return failures == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
