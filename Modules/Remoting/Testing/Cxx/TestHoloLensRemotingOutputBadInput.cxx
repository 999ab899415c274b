// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Bad set-ups give an error that says what to do, and no crash: no volume, a volume with
// another mapper, a network address without permission, a missing certificate, a page
// directory without the player, processing frames before Start().
#include "PathTracingTestScene.h"
#include "vtkHoloLensRemotingOutput.h"

#include "vtkFixedPointVolumeRayCastMapper.h"
#include "vtkTestErrorObserver.h"

#include <iostream>

namespace
{
int Failures = 0;

void ExpectError(vtkHoloLensRemotingOutput* output, vtkTest::ErrorObserver* observer,
  const std::string& fragment, const char* what)
{
  observer->Clear();
  const int started = output->Start();
  const std::string message = observer->GetError() ? observer->GetErrorMessage() : "";
  const bool ok = started == 0 && message.find(fragment) != std::string::npos;
  std::cout << (ok ? "ok: " : "FAILED: ") << what << " -> " << message << "\n";
  Failures += ok ? 0 : 1;
  output->Stop();
}
}

int TestHoloLensRemotingOutputBadInput(int, char*[])
{
  vtkNew<vtkTest::ErrorObserver> observer;
  vtkNew<vtkHoloLensRemotingOutput> output;
  output->AddObserver(vtkCommand::ErrorEvent, observer);
  output->SetPort(0);

  ExpectError(output, observer, "Set a vtkVolume whose mapper is a vtkPathTracedVolumeMapper", "no volume");

  vtkNew<vtkVolume> other;
  vtkNew<vtkFixedPointVolumeRayCastMapper> fixedPoint;
  other->SetMapper(fixedPoint);
  output->SetVolume(other);
  ExpectError(output, observer, "vtkPathTracedVolumeMapper", "a volume with another mapper");

  vtkNew<vtkVolume> volume;
  vtkNew<vtkPathTracedVolumeMapper> mapper;
  volume->SetMapper(mapper);
  output->SetVolume(volume);
  ExpectError(output, observer, "no input data", "a mapper without data");

  mapper->SetInputData(pathtracingtest::MakeVolume(16));
  output->SetBindAddress("0.0.0.0");
  ExpectError(output, observer, "--allow-remote", "a network address without permission");
  output->SetBindAddress("not-an-address");
  ExpectError(output, observer, "not an IP address", "an unusable bind address");
  output->SetBindAddress("127.0.0.1");

  output->SetCertificateFile("/nonexistent/certificate.pem");
  output->SetPrivateKeyFile("/nonexistent/key.pem");
  ExpectError(output, observer, "cannot use the TLS certificate", "a missing certificate");
  output->SetCertificateFile(nullptr);
  ExpectError(output, observer, "both a certificate file and a private key file", "a key without certificate");
  output->SetPrivateKeyFile(nullptr);

  output->SetWebRoot("/nonexistent");
  ExpectError(output, observer, "no index.html", "no player page");
  output->SetWebRoot(nullptr);

  output->SetAccessToken("short");
  ExpectError(output, observer, "at least 16 characters", "a short token");
  output->SetAccessToken(nullptr);

  vtkNew<vtkHoloLensRemotingOutput> idle;
  idle->AddObserver(vtkCommand::ErrorEvent, observer);
  observer->Clear();
  const bool refused = idle->ProcessFrame(0.0) == -1 && observer->GetError();
  std::cout << (refused ? "ok: " : "FAILED: ") << "ProcessFrame before Start\n";
  Failures += refused ? 0 : 1;

  // After all that, a good set-up starts.
  observer->Clear();
  const bool started = output->Start() == 1 && output->GetBoundPort() > 0 &&
    std::string(output->GetUrl()).find("token=") != std::string::npos;
  std::cout << (started ? "ok: " : "FAILED: ") << "a good set-up starts: " << output->GetUrl() << "\n";
  Failures += started ? 0 : 1;
  return Failures == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
