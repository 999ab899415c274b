// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// vtkDualFisheyeToEquirectangular: 8-bit sRGB, 16-bit sRGB and float frames of a synthetic
// panorama stitch back to it (>= 40 dB, solid-angle weighted) in VTK's row order; greyscale
// is replicated; presets work on reduced frames; clipped pixels are flagged; remap tables
// are rebuilt only when settings or sizes change; bad input (wrong aspect, no or unreadable
// calibration, odd output size, NaN, unsupported scalars) gives an error and an empty output.
#include "vtkDualFisheyeToEquirectangular.h"

#include "vtkExecutive.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkIntArray.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkStringArray.h"
#include "vtkTestErrorObserver.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnsignedShortArray.h"

#include "hv/lighting/DualFisheyeStitcher.h"
#include "hv/lighting/PanoramaMetrics.h"

#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <unistd.h>

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

constexpr double PiD = 3.14159265358979323846;

std::string TemporaryPath(const std::string& name)
{
  return "/tmp/holovolume-dualfisheye-test-" + std::to_string(getpid()) + "-" + name;
}

// Smooth colours plus a few 6-degree blobs, in [0.05, 0.9] (no clipping when encoded).
cv::Mat MakePanorama(const cv::Size& size)
{
  cv::Mat panorama(size, CV_32FC3);
  const double blobs[3][3] = { { 1, 0.2, 0 }, { 0.3, 0.4, -1 }, { -0.5, -0.3, 0.8 } };
  for (int y = 0; y < size.height; ++y)
  {
    for (int x = 0; x < size.width; ++x)
    {
      const double phi = ((x + 0.5) / size.width - 0.5) * 2.0 * PiD;
      const double theta = (y + 0.5) / size.height * PiD;
      const double d[3] = { std::sin(theta) * std::sin(phi), std::cos(theta),
        -std::sin(theta) * std::cos(phi) };
      double rgb[3] = { 0.35 + 0.15 * d[0] + 0.1 * d[1], 0.3 + 0.12 * d[2] - 0.08 * d[0] * d[1],
        0.32 + 0.15 * d[1] * d[2] };
      for (int b = 0; b < 3; ++b)
      {
        const double norm = std::sqrt(
          blobs[b][0] * blobs[b][0] + blobs[b][1] * blobs[b][1] + blobs[b][2] * blobs[b][2]);
        const double cosAngle =
          (d[0] * blobs[b][0] + d[1] * blobs[b][1] + d[2] * blobs[b][2]) / norm;
        const double angle = std::acos(std::max(-1.0, std::min(1.0, cosAngle)));
        const double sigma = 6.0 * PiD / 180.0;
        rgb[b] += 0.3 * std::exp(-0.5 * angle * angle / (sigma * sigma));
      }
      panorama.at<cv::Vec3f>(y, x) = cv::Vec3f(
        static_cast<float>(rgb[0]), static_cast<float>(rgb[1]), static_cast<float>(rgb[2]));
    }
  }
  return panorama;
}

// A 190-degree camera recording 512x256 frames.
hv::lighting::FisheyeCalibration SmallCamera()
{
  hv::lighting::FisheyeCalibration calibration;
  calibration.CameraName = "small test camera";
  calibration.FrameWidth = 512;
  calibration.FrameHeight = 256;
  for (auto* lens : { &calibration.Front, &calibration.Back })
  {
    lens->CenterX = 127.5;
    lens->CenterY = 127.5;
    lens->Radius = 125.0;
    lens->FieldOfViewDegrees = 190.0;
  }
  return calibration;
}

double LinearToSrgb(double linear)
{
  linear = std::max(0.0, std::min(1.0, linear));
  return linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
}

// A top-row-first cv::Mat frame as vtkImageData in VTK's row order, of the given scalar type
// (VTK_UNSIGNED_CHAR / VTK_UNSIGNED_SHORT: sRGB-encoded, VTK_FLOAT: linear).
vtkSmartPointer<vtkImageData> ToVtk(const cv::Mat& linear, int scalarType, int components = 3)
{
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(linear.cols, linear.rows, 1);
  vtkSmartPointer<vtkDataArray> array =
    vtkSmartPointer<vtkDataArray>::Take(vtkDataArray::CreateDataArray(scalarType));
  array->SetName("Frame");
  array->SetNumberOfComponents(components);
  array->SetNumberOfTuples(static_cast<vtkIdType>(linear.total()));
  const double scale = scalarType == VTK_UNSIGNED_CHAR ? 255.0 : 65535.0;
  for (int row = 0; row < linear.rows; ++row)
  {
    const int vtkRow = linear.rows - 1 - row;
    for (int x = 0; x < linear.cols; ++x)
    {
      const cv::Vec3f& value = linear.at<cv::Vec3f>(row, x);
      const vtkIdType id = static_cast<vtkIdType>(vtkRow) * linear.cols + x;
      for (int c = 0; c < components; ++c)
      {
        const double v = components == 1 ? (value[0] + value[1] + value[2]) / 3.0 : value[c];
        array->SetComponent(
          id, c, scalarType == VTK_FLOAT ? v : std::round(LinearToSrgb(v) * scale));
      }
    }
  }
  image->GetPointData()->SetScalars(array);
  return image;
}

// The output "Radiance" as a top-row-first cv::Mat.
cv::Mat FromVtk(vtkImageData* image)
{
  int dims[3];
  image->GetDimensions(dims);
  vtkFloatArray* radiance =
    vtkFloatArray::SafeDownCast(image->GetPointData()->GetArray("Radiance"));
  if (!radiance || dims[0] < 1)
  {
    return cv::Mat();
  }
  cv::Mat bottomUp(dims[1], dims[0], CV_32FC3, radiance->GetPointer(0));
  cv::Mat topDown;
  cv::flip(bottomUp, topDown, 0);
  return topDown;
}

struct Observed
{
  vtkNew<vtkTest::ErrorObserver> Observer;
  explicit Observed(vtkDualFisheyeToEquirectangular* filter)
  {
    filter->AddObserver(vtkCommand::ErrorEvent, this->Observer);
    filter->GetExecutive()->AddObserver(vtkCommand::ErrorEvent, this->Observer);
  }
  bool ErrorSays(const std::string& text)
  {
    const bool found = this->Observer->GetError() &&
      this->Observer->GetErrorMessage().find(text) != std::string::npos;
    // Logged for the reader, without the "ERROR:" that ctest's failure expression matches.
    std::string message = this->Observer->GetErrorMessage();
    for (std::size_t at = message.find("ERROR:"); at != std::string::npos;
         at = message.find("ERROR:", at))
    {
      message.replace(at, 6, "reported:");
    }
    std::cout << message << "\n";
    this->Observer->Clear();
    return found;
  }
};
}

int TestDualFisheyeToEquirectangular(int, char*[])
{
  const hv::lighting::FisheyeCalibration camera = SmallCamera();
  const std::string calibrationPath = TemporaryPath("camera.json");
  hv::lighting::saveCalibration(camera, calibrationPath);
  const cv::Mat panorama = MakePanorama(cv::Size(256, 128));
  const cv::Mat frame = hv::lighting::renderDualFisheye(panorama, camera, cv::Size(512, 256));

  // ---- round trips: 8-bit sRGB, 16-bit sRGB, float linear ----
  {
    vtkNew<vtkDualFisheyeToEquirectangular> stitcher;
    Observed observed(stitcher);
    stitcher->SetCalibrationFileName(calibrationPath.c_str());
    stitcher->SetOutputDimensions(256, 128);
    stitcher->ComputeClippedFractionOn();
    // 8-bit quantisation of linear values near 0.3 is about 0.004 per code: ~55 dB; 40 dB
    // leaves room, and a wrong row order or colour order would give < 20 dB.
    const struct
    {
      int Type;
      const char* Name;
      double MinimumPsnr;
      bool InterpolateEncoded;
    } cases[] = { { VTK_UNSIGNED_CHAR, "8-bit sRGB", 40.0, true },
      { VTK_UNSIGNED_CHAR, "8-bit sRGB linearised whole", 40.0, false },
      { VTK_UNSIGNED_SHORT, "16-bit sRGB", 40.0, true },
      { VTK_FLOAT, "float linear", 40.0, true } };
    for (const auto& c : cases)
    {
      vtkSmartPointer<vtkImageData> input = ToVtk(frame, c.Type);
      stitcher->SetInterpolateEncodedFrames(c.InterpolateEncoded);
      stitcher->SetInputData(input);
      stitcher->Update();
      Expect(!observed.Observer->GetError(), std::string(c.Name) + ": no error");
      vtkImageData* output = stitcher->GetOutput();
      int dims[3];
      output->GetDimensions(dims);
      Expect(dims[0] == 256 && dims[1] == 128 && dims[2] == 1, std::string(c.Name) + ": 256x128");
      const cv::Mat stitched = FromVtk(output);
      const double psnr =
        stitched.empty() ? 0.0 : hv::lighting::weightedPsnr(stitched, panorama, 1.0);
      std::cout << c.Name << " frame -> panorama: PSNR " << psnr << " dB\n";
      Expect(psnr >= c.MinimumPsnr, std::string(c.Name) + ": PSNR >= 40 dB");
      Expect(output->GetPointData()->GetScalars() &&
          std::string(output->GetPointData()->GetScalars()->GetName()) == "Radiance",
        std::string(c.Name) + ": scalars named Radiance");
      const bool integer = c.Type != VTK_FLOAT;
      Expect((output->GetPointData()->GetArray("ClippedFraction") != nullptr) == integer,
        std::string(c.Name) + ": ClippedFraction only for display-referred frames");
      vtkStringArray* encoding =
        vtkStringArray::SafeDownCast(output->GetFieldData()->GetAbstractArray("Encoding"));
      Expect(encoding && encoding->GetValue(0) == (integer ? "DisplayReferred" : "SceneLinear"),
        std::string(c.Name) + ": Encoding in the output's field data");
    }
    Expect(stitcher->GetNumberOfTableBuilds() == 1,
      "the remap tables were built once for four frames of the same size");
    std::ostringstream printed;
    stitcher->Print(printed);
    Expect(printed.str().find("NumberOfTableBuilds: 1") != std::string::npos, "PrintSelf");
    stitcher->SetOutputDimensions(128, 64);
    stitcher->Update();
    Expect(stitcher->GetNumberOfTableBuilds() == 2, "a new output size rebuilds the tables");

    // An 8-bit frame whose field data says SceneLinear is not put through the sRGB EOTF.
    vtkSmartPointer<vtkImageData> linearCodes = ToVtk(frame, VTK_FLOAT);
    vtkNew<vtkUnsignedCharArray> codes;
    codes->SetNumberOfComponents(3);
    codes->SetNumberOfTuples(linearCodes->GetNumberOfPoints());
    for (vtkIdType i = 0; i < 3 * linearCodes->GetNumberOfPoints(); ++i)
    {
      codes->SetValue(i,
        static_cast<unsigned char>(std::lround(255.0 *
          std::min(1.0f,
            vtkFloatArray::SafeDownCast(linearCodes->GetPointData()->GetScalars())->GetValue(i)))));
    }
    linearCodes->GetPointData()->SetScalars(codes);
    vtkNew<vtkStringArray> encoding;
    encoding->SetName("Encoding");
    encoding->InsertNextValue("SceneLinear");
    linearCodes->GetFieldData()->AddArray(encoding);
    stitcher->SetOutputDimensions(256, 128);
    stitcher->SetInputData(linearCodes);
    stitcher->Update();
    const double psnr = hv::lighting::weightedPsnr(FromVtk(stitcher->GetOutput()), panorama, 1.0);
    std::cout << "8-bit SceneLinear frame -> panorama: PSNR " << psnr << " dB\n";
    Expect(psnr >= 40.0, "8-bit SceneLinear codes are taken as linear");
  }

  // ---- greyscale: replicated into R, G, B (documented conversion) ----
  {
    vtkNew<vtkDualFisheyeToEquirectangular> stitcher;
    Observed observed(stitcher);
    stitcher->SetCalibrationFileName(calibrationPath.c_str());
    stitcher->SetInputData(ToVtk(frame, VTK_UNSIGNED_CHAR, 1));
    stitcher->Update();
    Expect(!observed.Observer->GetError(), "greyscale: no error");
    const cv::Mat stitched = FromVtk(stitcher->GetOutput());
    bool grey = !stitched.empty();
    float brightest = 0.0f;
    for (int i = 0; grey && i < static_cast<int>(stitched.total()); ++i)
    {
      const cv::Vec3f& v = stitched.at<cv::Vec3f>(i);
      grey = v[0] == v[1] && v[1] == v[2];
      brightest = std::max(brightest, v[0]);
    }
    Expect(grey && brightest > 0.3f, "greyscale frames give R = G = B, not black");
    Expect(!stitcher->GetOutput()->GetPointData()->GetArray("ClippedFraction"),
      "no ClippedFraction unless asked for");
  }

  // ---- a preset on a half-size frame; clipped pixels are flagged ----
  {
    vtkNew<vtkDualFisheyeToEquirectangular> stitcher;
    Observed observed(stitcher);
    stitcher->SetPreset("ricoh-theta");
    stitcher->ComputeClippedFractionOn();
    const cv::Mat grey(480, 960, CV_32FC3, cv::Scalar::all(0.2158605));
    stitcher->SetInputData(ToVtk(grey, VTK_UNSIGNED_CHAR)); // code 128
    stitcher->Update();
    Expect(!observed.Observer->GetError(), "preset on a 960x480 frame: no error");
    cv::Mat stitched = FromVtk(stitcher->GetOutput());
    Expect(!stitched.empty() && stitched.cols == 512 && stitched.rows == 256,
      "preset: default 512x256 output");
    if (!stitched.empty())
    {
      // Front axis (-Z) is the image centre, the back axis (+Z) the left edge.
      Expect(std::abs(stitched.at<cv::Vec3f>(128, 256)[1] - 0.2158605f) < 1e-4f &&
          std::abs(stitched.at<cv::Vec3f>(128, 0)[1] - 0.2158605f) < 1e-4f,
        "a uniform grey frame gives its linear value 0.2159 in both lenses");
    }
    vtkDataArray* clipped = stitcher->GetOutput()->GetPointData()->GetArray("ClippedFraction");
    Expect(clipped && clipped->GetRange(0)[1] == 0.0, "nothing clipped in a grey frame");
    const cv::Mat white(480, 960, CV_32FC3, cv::Scalar::all(1.0));
    stitcher->SetInputData(ToVtk(white, VTK_UNSIGNED_CHAR));
    stitcher->Update();
    clipped = stitcher->GetOutput()->GetPointData()->GetArray("ClippedFraction");
    Expect(clipped && clipped->GetRange(0)[0] == 1.0, "everything clipped in a white frame");
    Expect(stitcher->GetNumberOfTableBuilds() == 1, "same size, same preset: tables kept");

    // Full-size 1920x960 8-bit frames, linearised whole or halved first
    // (InputReductionFactor 2): same value on a uniform frame; time per frame of the whole
    // filter (conversion + stitch) on this machine's threads, for information.
    const cv::Mat full(960, 1920, CV_32FC3, cv::Scalar::all(0.2158605));
    stitcher->SetInputData(ToVtk(full, VTK_UNSIGNED_CHAR));
    const struct
    {
      bool Encoded;
      int Reduction;
      const char* Name;
    } paths[] = { { true, 1, "samples linearised (InterpolateEncodedFrames, default)" },
      { false, 1, "whole frame linearised" },
      { false, 2, "halved, then linearised (InputReductionFactor 2)" } };
    stitcher->ComputeClippedFractionOff(); // the defaults
    for (const auto& path : paths)
    {
      stitcher->SetInterpolateEncodedFrames(path.Encoded);
      stitcher->SetInputReductionFactor(path.Reduction);
      stitcher->Update();
      stitched = FromVtk(stitcher->GetOutput());
      Expect(
        !stitched.empty() && std::abs(stitched.at<cv::Vec3f>(128, 256)[1] - 0.2158605f) < 1e-4f,
        std::string("1920x960 frame, ") + path.Name + ": uniform grey preserved");
      const auto start = std::chrono::steady_clock::now();
      for (int i = 0; i < 5; ++i)
      {
        stitcher->GetInput()->Modified();
        stitcher->Update();
      }
      std::cout << "vtkDualFisheyeToEquirectangular, 1920x960 8-bit -> 512x256, " << path.Name
                << ": "
                << std::chrono::duration<double, std::milli>(
                     std::chrono::steady_clock::now() - start)
                     .count() /
          5.0 << " ms per frame\n";
    }
    Expect(stitcher->GetNumberOfTableBuilds() == 3, "new frame sizes rebuild the tables");
    stitcher->SetInputReductionFactor(3);
    stitcher->Update();
    Expect(observed.ErrorSays("power of two"), "InputReductionFactor 3: an error");
  }

  // ---- bad input: error message, empty output, no crash ----
  {
    vtkNew<vtkDualFisheyeToEquirectangular> stitcher;
    Observed observed(stitcher);
    stitcher->SetInputData(ToVtk(frame, VTK_UNSIGNED_CHAR));
    stitcher->Update();
    Expect(observed.ErrorSays("SetPreset") && stitcher->GetOutput()->GetNumberOfPoints() == 0,
      "missing calibration: an error that says to set a preset");
    stitcher->SetPreset("theta-z99");
    stitcher->Update();
    Expect(observed.ErrorSays("insta360-one-x"), "an unknown preset lists the presets");

    const std::string broken = TemporaryPath("broken.json");
    std::ofstream(broken) << "{ \"schemaVersion\": 1, \"frame\": ";
    stitcher->SetCalibrationFileName(broken.c_str());
    stitcher->Update();
    Expect(observed.ErrorSays("JSON") && stitcher->GetOutput()->GetNumberOfPoints() == 0,
      "unreadable JSON: an error");
    std::remove(broken.c_str());
    stitcher->SetCalibrationFileName("/nonexistent/camera.json");
    stitcher->Update();
    Expect(observed.ErrorSays("/nonexistent/camera.json"), "a missing file is named");

    stitcher->SetCalibrationFileName(calibrationPath.c_str());
    stitcher->SetInputData(
      ToVtk(cv::Mat(300, 512, CV_32FC3, cv::Scalar::all(0.5)), VTK_UNSIGNED_CHAR));
    stitcher->Update();
    Expect(observed.ErrorSays("aspect ratio") && stitcher->GetOutput()->GetNumberOfPoints() == 0,
      "a 512x300 frame for a 2:1 calibration: aspect ratio error");

    stitcher->SetInputData(ToVtk(frame, VTK_UNSIGNED_CHAR));
    stitcher->SetOutputDimensions(500, 256);
    stitcher->Update();
    Expect(observed.ErrorSays("twice as wide"), "output 500x256: error");
    stitcher->SetOutputDimensions(512, 256);

    vtkSmartPointer<vtkImageData> withNaN = ToVtk(frame, VTK_FLOAT);
    vtkFloatArray::SafeDownCast(withNaN->GetPointData()->GetScalars())
      ->SetValue(1000, std::numeric_limits<float>::quiet_NaN());
    stitcher->SetInputData(withNaN);
    stitcher->Update();
    Expect(observed.ErrorSays("NaN") && stitcher->GetOutput()->GetNumberOfPoints() == 0,
      "NaN in a float frame: an error");

    vtkNew<vtkImageData> integers;
    integers->SetDimensions(512, 256, 1);
    vtkNew<vtkIntArray> values;
    values->SetNumberOfComponents(3);
    values->SetNumberOfTuples(512 * 256);
    values->Fill(0);
    integers->GetPointData()->SetScalars(values);
    stitcher->SetInputData(integers);
    stitcher->Update();
    Expect(observed.ErrorSays("vtkImageCast"), "int scalars: an error suggesting vtkImageCast");

    // Fixed input after the errors: the filter works again.
    stitcher->SetInputData(ToVtk(frame, VTK_FLOAT));
    stitcher->Update();
    Expect(
      !observed.Observer->GetError() && stitcher->GetOutput()->GetNumberOfPoints() == 512 * 256,
      "after the errors a good frame stitches");
  }
  std::remove(calibrationPath.c_str());
  return failures == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
