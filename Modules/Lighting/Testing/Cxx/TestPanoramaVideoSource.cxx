// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// vtkPanoramaVideoSource in a pipeline: an Update() without a newer frame does not re-execute,
// one with a newer frame does; rows are flipped into VTK's order; the scalar type follows the
// frame (8-bit, 16-bit, float); field data carries index, time, encoding and drops; bad
// sources are reported through vtkErrorMacro without a crash.
#include "vtkPanoramaVideoSource.h"

#include "vtkCallbackCommand.h"
#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkExecutive.h"
#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkNew.h"
#include "vtkPNGWriter.h"
#include "vtkPointData.h"
#include "vtkStringArray.h"
#include "vtkTestErrorObserver.h"
#include "vtkTypeInt64Array.h"

#include "hv/lighting/PanoramaFrameGrabber.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <thread>
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

// Frame k of the sequence, 512x256 (the paper's panorama size) in VTK's row order:
// R = x / 2, G = j (the VTK row, so the flip shows), B = 20 + 50 k.
vtkSmartPointer<vtkImageData> MakeFrame(int k)
{
  const int width = 512, height = 256;
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(width, height, 1);
  image->AllocateScalars(VTK_UNSIGNED_CHAR, 3);
  auto* p = static_cast<unsigned char*>(image->GetScalarPointer());
  for (int j = 0; j < height; ++j)
  {
    for (int i = 0; i < width; ++i, p += 3)
    {
      p[0] = static_cast<unsigned char>(i / 2);
      p[1] = static_cast<unsigned char>(j);
      p[2] = static_cast<unsigned char>(20 + 50 * k);
    }
  }
  return image;
}

void WritePng(vtkImageData* image, const std::string& path)
{
  vtkNew<vtkPNGWriter> writer;
  writer->SetInputData(image);
  writer->SetFileName(path.c_str());
  writer->Write();
}

// Same scalars (type, components, values)?
bool SameScalars(vtkImageData* a, vtkImageData* b)
{
  vtkDataArray* x = a->GetPointData()->GetScalars();
  vtkDataArray* y = b->GetPointData()->GetScalars();
  if (!x || !y || x->GetDataType() != y->GetDataType() ||
    x->GetNumberOfComponents() != y->GetNumberOfComponents() ||
    x->GetNumberOfTuples() != y->GetNumberOfTuples())
  {
    return false;
  }
  const vtkIdType n = x->GetNumberOfValues();
  for (vtkIdType v = 0; v < n; ++v)
  {
    if (x->GetVariantValue(v) != y->GetVariantValue(v))
    {
      return false;
    }
  }
  return true;
}

// A Portable Float Map: the simplest float RGB file OpenImageIO reads (header, then
// little-endian float rows from the bottom up). Written by hand because the test has no
// image writer for float data; vtkPNGWriter covers the 8- and 16-bit cases.
void WritePfm(const std::string& path, int width, int height, const std::vector<float>& bottomUp)
{
  std::ofstream file(path, std::ios::binary);
  file << "PF\n" << width << " " << height << "\n-1.0\n";
  file.write(reinterpret_cast<const char*>(bottomUp.data()),
    static_cast<std::streamsize>(bottomUp.size() * sizeof(float)));
}

template <typename Action>
std::string ErrorOf(vtkPanoramaVideoSource* source, Action action)
{
  vtkNew<vtkTest::ErrorObserver> observer;
  const unsigned long errorTag = source->AddObserver(vtkCommand::ErrorEvent, observer);
  const unsigned long executiveTag =
    source->GetExecutive()->AddObserver(vtkCommand::ErrorEvent, observer);
  action();
  source->RemoveObserver(errorTag);
  source->GetExecutive()->RemoveObserver(executiveTag);
  return observer->GetError() ? observer->GetErrorMessage() : std::string();
}

double Ms(std::chrono::steady_clock::time_point start)
{
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
    .count();
}

template <typename Predicate>
bool WaitUntil(Predicate predicate, double seconds)
{
  const auto start = std::chrono::steady_clock::now();
  while (Ms(start) < 1000.0 * seconds)
  {
    if (predicate())
    {
      return true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return predicate();
}

vtkTypeInt64 FieldInt(vtkImageData* image, const char* name)
{
  auto* array = vtkTypeInt64Array::SafeDownCast(image->GetFieldData()->GetAbstractArray(name));
  return array && array->GetNumberOfValues() == 1 ? array->GetValue(0) : -999;
}
}

int TestPanoramaVideoSource(int, char*[])
{
  const std::string directory = "/tmp/holovolume-videosource-test-" + std::to_string(getpid());
  std::filesystem::create_directories(directory);

  // --- A paced sequence of three frames at 1 frame/s: frames arrive at known moments.
  std::vector<vtkSmartPointer<vtkImageData>> frames;
  for (int k = 0; k < 3; ++k)
  {
    frames.push_back(MakeFrame(k));
    char name[64];
    std::snprintf(name, sizeof(name), "/pano_%04d.png", k);
    WritePng(frames.back(), directory + name);
  }
  {
    vtkNew<vtkPanoramaVideoSource> source;
    source->SetSource((directory + "/pano_%04d.png").c_str());
    source->PaceToFrameRateOn();
    source->SetDefaultFrameRate(1.0);
    int executions = 0;
    vtkNew<vtkCallbackCommand> counter;
    counter->SetClientData(&executions);
    counter->SetCallback(
      [](vtkObject*, unsigned long, void* count, void*) { ++*static_cast<int*>(count); });
    source->AddObserver(vtkCommand::EndEvent, counter);

    auto start = std::chrono::steady_clock::now();
    source->Update(); // opens the source
    const double firstUpdateMs = Ms(start);
    vtkImageData* output = source->GetOutput();
    Expect(executions == 1, "first Update executes once");
    Expect(std::string(source->GetSourceKind()) == "ImageSequence", "source kind");
    int dims[3];
    output->GetDimensions(dims);
    Expect(dims[0] == 512 && dims[1] == 256 && dims[2] == 1, "output is 512x256");
    vtkDataArray* scalars = output->GetPointData()->GetScalars();
    Expect(scalars && std::string(scalars->GetName()) == "Frame" &&
        scalars->GetDataType() == VTK_UNSIGNED_CHAR && scalars->GetNumberOfComponents() == 3,
      "scalars 'Frame', unsigned char x 3");
    // vtkPNGWriter wrote VTK's row 0 as the file's bottom row; reading it back must give the
    // same image, i.e. the source flipped the file's top row to VTK's last row.
    Expect(SameScalars(output, frames[0]), "frame 0 equals the written image (rows flipped back)");
    const hv::lighting::PanoramaFrame file =
      hv::lighting::PanoramaFrameGrabber::readImage(directory + "/pano_0000.png");
    const cv::Vec3b topLeft = file.Image.at<cv::Vec3b>(0, 0);
    Expect(topLeft[1] == 255 && output->GetScalarComponentAsDouble(0, 255, 0, 1) == topLeft[1] &&
        output->GetScalarComponentAsDouble(0, 0, 0, 1) == 0.0,
      "the picture's top row is VTK's last row");
    Expect(FieldInt(output, "FrameIndex") == 0, "FrameIndex 0");
    Expect(FieldInt(output, "FramesDropped") == 0, "FramesDropped 0");
    auto* encoding =
      vtkStringArray::SafeDownCast(output->GetFieldData()->GetAbstractArray("Encoding"));
    Expect(encoding && encoding->GetValue(0) == "DisplayReferred", "Encoding DisplayReferred");
    auto* timestamp =
      vtkDoubleArray::SafeDownCast(output->GetFieldData()->GetAbstractArray("Timestamp"));
    Expect(timestamp && timestamp->GetValue(0) > 0.0 &&
        timestamp->GetValue(0) == source->GetFrameTimestamp(),
      "Timestamp");

    // No newer frame yet (the next is due 1 s after Open): no re-execution, same MTime.
    const vtkMTimeType sourceTime = source->GetMTime();
    const vtkMTimeType outputTime = output->GetMTime();
    start = std::chrono::steady_clock::now();
    source->Update();
    const double idleUpdateMs = Ms(start);
    Expect(executions == 1, "Update without a new frame does not re-execute");
    Expect(source->GetMTime() == sourceTime && output->GetMTime() == outputTime,
      "MTime unchanged without a new frame");

    // A consumer that keeps frame 0 (a shallow copy shares the scalars) must keep it.
    vtkNew<vtkImageData> kept;
    kept->ShallowCopy(output);

    // Frame 1 arrives: the next Update takes it.
    Expect(WaitUntil([&] { return source->GetFramesReceived() >= 2; }, 5.0), "frame 1 arrives");
    start = std::chrono::steady_clock::now();
    source->Update();
    const double newFrameUpdateMs = Ms(start);
    Expect(executions == 2, "a new frame re-executes");
    Expect(FieldInt(output, "FrameIndex") == 1 && SameScalars(output, frames[1]), "frame 1 output");
    Expect(source->GetMTime() > sourceTime, "MTime grows with a new frame");
    Expect(SameScalars(kept, frames[0]), "a kept frame is not overwritten by the next");
    source->Update();
    Expect(executions == 2, "and only once");

    // AutoAdvance off: frame 2 waits for UpdateToNewestFrame(). (Switching it off is a
    // parameter change, which re-executes once with the same frame.)
    source->AutoAdvanceOff();
    source->Update();
    Expect(executions == 3 && FieldInt(output, "FrameIndex") == 1, "AutoAdvanceOff re-executes");
    Expect(WaitUntil([&] { return source->GetFramesReceived() >= 3; }, 5.0), "frame 2 arrives");
    source->Update();
    Expect(executions == 3 && FieldInt(output, "FrameIndex") == 1, "AutoAdvance off holds frame 1");
    Expect(source->UpdateToNewestFrame(), "UpdateToNewestFrame takes frame 2");
    source->Update();
    Expect(executions == 4 && FieldInt(output, "FrameIndex") == 2 && SameScalars(output, frames[2]),
      "frame 2 output");
    Expect(!source->UpdateToNewestFrame(), "no frame after the last");
    Expect(WaitUntil([&] { return source->GetFinished(); }, 5.0), "sequence finished");
    Expect(!source->WaitForNewFrame(0.5), "WaitForNewFrame returns false at the end");
    Expect(source->GetFramesDropped() == 0, "a paced sequence drops nothing");

    std::ostringstream printed;
    source->Print(printed);
    Expect(printed.str().find("FramesReceived: 3") != std::string::npos, "PrintSelf");
    std::cout << "first Update (open + decode) " << firstUpdateMs << " ms, Update without new "
              << "frame " << idleUpdateMs << " ms, Update with a new 512x256 frame "
              << newFrameUpdateMs << " ms\n";
    Expect(idleUpdateMs < 5.0, "an Update without a new frame returns at once");

    // Changing the source closes the open one; the next Update opens the new one.
    source->SetSource((directory + "/pano_0001.png").c_str());
    Expect(!source->IsOpen(), "SetSource closes");
    source->Update();
    Expect(executions == 5 && SameScalars(output, frames[1]) &&
        std::string(source->GetSourceKind()) == "ImageFile",
      "a still image after SetSource");
  }

  // --- DeliverEveryFrame: the same three frames unpaced, decoded in about a millisecond each,
  // and a pipeline that updates every 100 ms. Without the option the second Update finds the
  // decoder at the end (waited for, so that a loaded machine cannot make it look right) and
  // skips frame 1; with it every Update takes the next frame.
  for (const bool everyFrame : { false, true })
  {
    vtkNew<vtkPanoramaVideoSource> source;
    source->SetSource((directory + "/pano_%04d.png").c_str());
    source->SetDeliverEveryFrame(everyFrame);
    std::vector<vtkTypeInt64> taken;
    for (int update = 0; update < 3; ++update)
    {
      source->Update();
      taken.push_back(FieldInt(source->GetOutput(), "FrameIndex"));
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      if (!everyFrame)
      {
        Expect(WaitUntil([&] { return source->GetFinished(); }, 5.0),
          "DeliverEveryFrame off: the decoder reaches the end");
      }
    }
    const std::string label = everyFrame ? "DeliverEveryFrame on" : "DeliverEveryFrame off";
    if (everyFrame)
    {
      Expect(taken == std::vector<vtkTypeInt64>{ 0, 1, 2 }, label + ": frames 0, 1, 2 in turn");
      Expect(SameScalars(source->GetOutput(), frames[2]), label + ": the last frame's pixels");
      Expect(source->GetFramesDropped() == 0, label + ": nothing dropped");
    }
    else
    {
      Expect(taken[1] == 2 && source->GetFramesDropped() == 1,
        label + ": the decoder ran ahead and frame 1 was dropped");
    }
    std::ostringstream printed;
    source->Print(printed);
    Expect(printed.str().find(std::string("DeliverEveryFrame: ") + (everyFrame ? "On" : "Off")) !=
        std::string::npos,
      label + ": PrintSelf");
  }

  // --- 16-bit PNG: unsigned short scalars.
  {
    auto image = vtkSmartPointer<vtkImageData>::New();
    image->SetDimensions(64, 32, 1);
    image->AllocateScalars(VTK_UNSIGNED_SHORT, 3);
    auto* p = static_cast<unsigned short*>(image->GetScalarPointer());
    for (int v = 0; v < 64 * 32 * 3; ++v)
    {
      p[v] = static_cast<unsigned short>(1000 * (v % 3) + 7 * (v / 3) + 300);
    }
    WritePng(image, directory + "/deep.png");
    vtkNew<vtkPanoramaVideoSource> source;
    source->SetSource((directory + "/deep.png").c_str());
    source->Update();
    vtkDataArray* scalars = source->GetOutput()->GetPointData()->GetScalars();
    Expect(scalars && scalars->GetDataType() == VTK_UNSIGNED_SHORT, "16-bit PNG: unsigned short");
    Expect(SameScalars(source->GetOutput(), image), "16-bit PNG values and rows");
  }

  // --- Float (PFM through OpenImageIO): float scalars, SceneLinear; NaN is an error unless
  // ReplaceNonFiniteValues is on.
  {
    const int width = 16, height = 8;
    std::vector<float> bottomUp(width * height * 3);
    for (int j = 0; j < height; ++j)
    {
      for (int i = 0; i < width; ++i)
      {
        float* p = &bottomUp[3 * (j * width + i)];
        p[0] = 0.5f * i;
        p[1] = static_cast<float>(j);
        p[2] = 1000.0f;
      }
    }
    WritePfm(directory + "/radiance.pfm", width, height, bottomUp);
    vtkNew<vtkPanoramaVideoSource> source;
    source->SetSource((directory + "/radiance.pfm").c_str());
    source->Update();
    vtkImageData* output = source->GetOutput();
    vtkDataArray* scalars = output->GetPointData()->GetScalars();
    Expect(scalars && scalars->GetDataType() == VTK_FLOAT, "PFM: float scalars");
    Expect(std::string(source->GetFrameEncoding()) == "SceneLinear", "PFM: SceneLinear");
    bool same = scalars != nullptr;
    for (int v = 0; same && v < width * height * 3; ++v)
    {
      same = scalars->GetComponent(v / 3, v % 3) == bottomUp[v];
    }
    Expect(same, "PFM values, VTK row j = the file's j-th row from the bottom");

    bottomUp[3 * 5 + 1] = std::numeric_limits<float>::quiet_NaN();
    WritePfm(directory + "/nan.pfm", width, height, bottomUp);
    vtkNew<vtkPanoramaVideoSource> bad;
    bad->SetSource((directory + "/nan.pfm").c_str());
    const std::string message = ErrorOf(bad, [&] { bad->Update(); });
    Expect(message.find("NaN") != std::string::npos &&
        message.find("ReplaceNonFiniteValues") != std::string::npos,
      "NaN reported: '" + message + "'");
    bad->ReplaceNonFiniteValuesOn();
    Expect(ErrorOf(bad, [&] { bad->Update(); }).empty(), "NaN replaced without error");
    Expect(bad->GetOutput()->GetPointData()->GetScalars()->GetComponent(5, 1) == 0.0,
      "NaN replaced by 0");
  }

  // --- Unopenable sources: vtkErrorMacro with what to check, no crash.
  {
    vtkNew<vtkPanoramaVideoSource> source;
    std::string message = ErrorOf(source, [&] { source->Update(); });
    Expect(message.find("No source") != std::string::npos, "no source: '" + message + "'");

    source->SetSource((directory + "/missing.mp4").c_str());
    message = ErrorOf(source, [&] { source->Update(); });
    Expect(message.find("does not exist") != std::string::npos, "missing file: '" + message + "'");
    Expect(!source->IsOpen(), "not open after a failure");

    source->SetSource("/dev/video99");
    message = ErrorOf(source, [&] { Expect(!source->Open(), "Open() returns false"); });
    Expect(message.find("camera") != std::string::npos, "bad camera: '" + message + "'");

    source->SetSource("http://127.0.0.1:1/none.ts");
    source->SetOpenTimeout(2.0);
    message = ErrorOf(source, [&] { source->Update(); });
    Expect(message.find("reachable") != std::string::npos, "bad URL: '" + message + "'");
  }

  std::error_code ignored;
  std::filesystem::remove_all(directory, ignored);
  return failures == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
