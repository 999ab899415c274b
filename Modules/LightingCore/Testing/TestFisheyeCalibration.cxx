// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// FisheyeCalibration: exact JSON round trip of every field, presets (built in and the JSON
// files in presets/ agree), errors that name the offending key, the lens placement and
// orientation in the frame, and the calibration helpers (image circle, vignetting fit).
#include "hv/lighting/DualFisheyeStitcher.h"
#include "hv/lighting/FisheyeCalibration.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <iostream>
#include <string>
#include <unistd.h>
#include <vector>

namespace
{
using namespace hv::lighting;
using Json = nlohmann::ordered_json;

constexpr double PiD = 3.14159265358979323846;

// Every field away from its default, with values that do not print exactly in decimal.
FisheyeCalibration unusualCalibration()
{
  FisheyeCalibration c;
  c.CameraName = "lab rig \"B\" \xc3\xa9";
  c.Notes = "line 1\nline 2";
  c.FrameWidth = 2880;
  c.FrameHeight = 1440;
  c.FrontLensHalf = FrontHalf::Right;
  c.Front.Model = hv::FisheyeProjection::KannalaBrandt;
  c.Front.CenterX = 719.5 + 1.0 / 3.0;
  c.Front.CenterY = 0.1 + 0.2 + 719.0;
  c.Front.Radius = 708.25;
  c.Front.FieldOfViewDegrees = 197.3;
  c.Front.FocalLength = 405.123456789012;
  c.Front.KannalaBrandt = { { 0.0312, -0.00811, 1.0 / 7.0 * 1e-3, -2.5e-5 } };
  c.Front.Vignetting = { { -0.31, 0.047, -0.0123 } };
  c.Front.ExposureGain = 0.97;
  c.Front.WhiteBalance = { { 1.02, 1.0, 0.93 } };
  c.Front.RollDegrees = 90.0;
  c.Back.Model = hv::FisheyeProjection::Equisolid;
  c.Back.CenterX = 721.1;
  c.Back.CenterY = 718.9;
  c.Back.Radius = 707.0 + 1e-9;
  c.Back.FieldOfViewDegrees = 193.0;
  c.Back.Vignetting = { { -0.2, 0.0, 0.0 } };
  c.Back.ExposureGain = 1.0 / 3.0;
  c.Back.WhiteBalance = { { 0.99, 1.01, 1.07 } };
  c.Back.YawDegrees = 0.7;
  c.Back.PitchDegrees = -0.35;
  c.Back.RollDegrees = -89.6;
  c.Stitching.BlendBandDegrees = 6.5;
  c.Stitching.AutomaticGainMatching = false;
  c.Stitching.GainSmoothing = 0.85;
  return c;
}

std::string temporaryPath(const std::string& name)
{
  return "/tmp/holovolume-fisheye-calibration-" + std::to_string(getpid()) + "-" + name;
}

void expectLensesEqual(const FisheyeLensCalibration& a, const FisheyeLensCalibration& b)
{
  EXPECT_EQ(a.Model, b.Model);
  EXPECT_EQ(a.CenterX, b.CenterX);
  EXPECT_EQ(a.CenterY, b.CenterY);
  EXPECT_EQ(a.Radius, b.Radius);
  EXPECT_EQ(a.FieldOfViewDegrees, b.FieldOfViewDegrees);
  EXPECT_EQ(a.FocalLength, b.FocalLength);
  EXPECT_EQ(a.KannalaBrandt, b.KannalaBrandt);
  EXPECT_EQ(a.Vignetting, b.Vignetting);
  EXPECT_EQ(a.ExposureGain, b.ExposureGain);
  EXPECT_EQ(a.WhiteBalance, b.WhiteBalance);
  EXPECT_EQ(a.YawDegrees, b.YawDegrees);
  EXPECT_EQ(a.PitchDegrees, b.PitchDegrees);
  EXPECT_EQ(a.RollDegrees, b.RollDegrees);
}

// The message of the exception `call` throws (of type E), or "" if it throws nothing.
template <typename E, typename F>
std::string errorOf(F call)
{
  try
  {
    call();
  }
  catch (const E& error)
  {
    return error.what();
  }
  return "";
}

// A valid calibration as JSON, modified by `edit`, then parsed: the error message.
template <typename Edit>
std::string errorAfterEdit(Edit edit)
{
  Json json = Json::parse(toJson(presetCalibration("ricoh-theta")));
  edit(json);
  return errorOf<std::invalid_argument>([&] { fromJson(json.dump()); });
}
}

TEST(FisheyeCalibration, JsonRoundTripIsExact)
{
  const FisheyeCalibration original = unusualCalibration();
  const std::string path = temporaryPath("roundtrip.json");
  saveCalibration(original, path);
  const FisheyeCalibration loaded = loadCalibration(path);
  std::remove(path.c_str());
  EXPECT_EQ(loaded.CameraName, original.CameraName);
  EXPECT_EQ(loaded.Notes, original.Notes);
  EXPECT_EQ(loaded.FrameWidth, original.FrameWidth);
  EXPECT_EQ(loaded.FrameHeight, original.FrameHeight);
  EXPECT_EQ(loaded.FrontLensHalf, original.FrontLensHalf);
  expectLensesEqual(loaded.Front, original.Front);
  expectLensesEqual(loaded.Back, original.Back);
  EXPECT_EQ(loaded.Stitching.BlendBandDegrees, original.Stitching.BlendBandDegrees);
  EXPECT_EQ(loaded.Stitching.AutomaticGainMatching, original.Stitching.AutomaticGainMatching);
  EXPECT_EQ(loaded.Stitching.GainSmoothing, original.Stitching.GainSmoothing);
  EXPECT_TRUE(loaded == original);
  EXPECT_EQ(toJson(loaded), toJson(original));
  // The file carries its schema version.
  EXPECT_EQ(Json::parse(toJson(original))["schemaVersion"], FisheyeCalibration::SchemaVersion);
}

// Optional keys take their documented defaults.
TEST(FisheyeCalibration, MinimalFileUsesDefaults)
{
  const std::string text = R"({
    "schemaVersion": 1,
    "frame": { "width": 1920, "height": 960 },
    "lenses": {
      "front": { "model": "equidistant", "center": [479.5, 479.5], "radius": 470,
                 "fieldOfViewDegrees": 190 },
      "back": { "model": "equisolid", "center": [480, 479], "radius": 468,
                "fieldOfViewDegrees": 192 }
    }
  })";
  const FisheyeCalibration c = fromJson(text);
  EXPECT_EQ(c.FrontLensHalf, FrontHalf::Left);
  EXPECT_EQ(c.Back.Model, hv::FisheyeProjection::Equisolid);
  EXPECT_EQ(c.Back.FieldOfViewDegrees, 192.0);
  EXPECT_EQ(c.Front.ExposureGain, 1.0);
  EXPECT_EQ(c.Front.Vignetting[0], 0.0);
  EXPECT_EQ(c.Stitching, StitchingOptions());
}

TEST(FisheyeCalibration, PresetsLoadAndMatchTheirFiles)
{
  const std::vector<std::string> names = calibrationPresetNames();
  ASSERT_EQ(names.size(), 2u);
  const FisheyeCalibration insta = presetCalibration("insta360-one-x");
  EXPECT_EQ(insta.FrameWidth, 3040);
  EXPECT_EQ(insta.FrameHeight, 1520);
  EXPECT_EQ(insta.Front.FieldOfViewDegrees, 200.0);
  const FisheyeCalibration theta = presetCalibration("ricoh-theta");
  EXPECT_EQ(theta.FrameWidth, 1920);
  EXPECT_EQ(theta.FrameHeight, 960);
  EXPECT_EQ(theta.Back.FieldOfViewDegrees, 190.0);
  // Modules/LightingCore/presets/<name>.json holds the same values as the built-in preset.
  std::string presets = __FILE__;
  presets = presets.substr(0, presets.rfind('/')) + "/../presets/";
  for (const std::string& name : names)
  {
    const FisheyeCalibration preset = presetCalibration(name);
    EXPECT_NO_THROW(validateCalibration(preset));
    EXPECT_TRUE(loadCalibration(presets + name + ".json") == preset) << name;
    // Both stitch: a 190-200 degree pair overlaps.
    DualFisheyeStitcher stitcher;
    stitcher.configure(preset, cv::Size(preset.FrameWidth, preset.FrameHeight));
    EXPECT_GT(cv::countNonZero(stitcher.overlapMask()), 0) << name;
  }
  const std::string error = errorOf<std::invalid_argument>([] { presetCalibration("gopro"); });
  EXPECT_NE(error.find("insta360-one-x"), std::string::npos) << error;
  EXPECT_NE(error.find("ricoh-theta"), std::string::npos) << error;
}

// Every error names the key to fix.
TEST(FisheyeCalibration, BadJsonNamesTheKey)
{
  struct Case
  {
    const char* key;
    std::function<void(Json&)> edit;
  };
  const std::vector<Case> cases = {
    { "lenses.back.radius", [](Json& j) { j["lenses"]["back"].erase("radius"); } },
    { "lenses.front.fieldOfViewDegrees",
      [](Json& j) { j["lenses"]["front"].erase("fieldOfViewDegrees"); } },
    { "frame.width", [](Json& j) { j["frame"].erase("width"); } },
    { "schemaVersion", [](Json& j) { j.erase("schemaVersion"); } },
    { "lenses", [](Json& j) { j.erase("lenses"); } },
    { "lenses.front.radius", [](Json& j) { j["lenses"]["front"]["radius"] = "470"; } },
    { "frame.height", [](Json& j) { j["frame"]["height"] = 960.5; } },
    { "lenses.back.center",
      [](Json& j) {
        j["lenses"]["back"]["center"] = { 1, 2, 3 };
      } },
    { "lenses.back.whiteBalance[1]",
      [](Json& j) { j["lenses"]["back"]["whiteBalance"][1] = nullptr; } },
    { "stitching.automaticGainMatching",
      [](Json& j) { j["stitching"]["automaticGainMatching"] = 1; } },
    { "lenses.front.fieldOfViewDegrees",
      [](Json& j) { j["lenses"]["front"]["fieldOfViewDegrees"] = 260; } },
    { "lenses.back.fieldOfViewDegrees",
      [](Json& j) { j["lenses"]["back"]["fieldOfViewDegrees"] = 0; } },
    { "lenses.back.fieldOfViewDegrees",
      [](Json& j) { j["lenses"]["back"]["fieldOfViewDegrees"] = -10; } },
    { "lenses.front.model", [](Json& j) { j["lenses"]["front"]["model"] = "fisheye"; } },
    { "lenses.front.fov", [](Json& j) { j["lenses"]["front"]["fov"] = 190; } },
    { "schemaVersion", [](Json& j) { j["schemaVersion"] = 2; } },
    { "frame.frontHalf", [](Json& j) { j["frame"]["frontHalf"] = "top"; } },
    { "frame.layout", [](Json& j) { j["frame"]["layout"] = "top-bottom"; } },
    { "lenses.front.center",
      [](Json& j) {
        j["lenses"]["front"]["center"] = { 1500, 480 };
      } },
    { "lenses.back.vignetting",
      [](Json& j) {
        j["lenses"]["back"]["vignetting"] = { -1.2, 0, 0 };
      } },
    { "lenses.back.kannalaBrandt",
      [](Json& j)
      {
        j["lenses"]["back"]["model"] = "kannala-brandt";
        j["lenses"]["back"]["kannalaBrandt"] = { -0.5, 0, 0, 0 };
      } },
    { "lenses.front.exposureGain", [](Json& j) { j["lenses"]["front"]["exposureGain"] = 0; } },
    { "lenses.back.rotationDegrees.yaw",
      [](Json& j) { j["lenses"]["back"]["rotationDegrees"]["yaw"] = 270; } },
    { "stitching.gainSmoothing", [](Json& j) { j["stitching"]["gainSmoothing"] = 1.0; } },
    { "stitching.blendBandDegrees", [](Json& j) { j["stitching"]["blendBandDegrees"] = -1; } },
  };
  for (const Case& c : cases)
  {
    const std::string error = errorAfterEdit(c.edit);
    EXPECT_NE(error.find(std::string("'") + c.key + "'"), std::string::npos)
      << "expected the key " << c.key << " in: '" << error << "'";
  }
  // Not JSON at all, or not an object: a runtime_error / invalid_argument, no crash.
  EXPECT_NE(errorOf<std::runtime_error>([] { fromJson("{ \"schemaVersion\": 1,"); }).find("JSON"),
    std::string::npos);
  EXPECT_NE(errorOf<std::invalid_argument>([] { fromJson("[1, 2]"); }), "");
  // A missing file names the path.
  const std::string missing = temporaryPath("missing.json");
  EXPECT_NE(errorOf<std::runtime_error>([&] { loadCalibration(missing); }).find(missing),
    std::string::npos);
  // A bad file names the path and the key.
  const std::string bad = temporaryPath("bad.json");
  {
    Json json = Json::parse(toJson(presetCalibration("ricoh-theta")));
    json["lenses"]["front"]["fieldOfViewDegrees"] = 300;
    std::ofstream(bad) << json.dump();
  }
  const std::string error = errorOf<std::invalid_argument>([&] { loadCalibration(bad); });
  std::remove(bad.c_str());
  EXPECT_NE(error.find(bad), std::string::npos) << error;
  EXPECT_NE(error.find("lenses.front.fieldOfViewDegrees"), std::string::npos) << error;
  // Saving an invalid calibration is refused too.
  FisheyeCalibration invalid = presetCalibration("ricoh-theta");
  invalid.Front.Radius = -1.0;
  EXPECT_NE(errorOf<std::invalid_argument>([&] { saveCalibration(invalid, bad); })
              .find("lenses.front.radius"),
    std::string::npos);
}

// Placement in the frame: centres are per half, scaled with the pixel-centre convention to
// reduced frames; another aspect ratio is refused.
TEST(FisheyeCalibration, LensPlacementAndScaling)
{
  FisheyeCalibration c = presetCalibration("ricoh-theta");
  c.Front.CenterX = 481.0;
  c.Back.CenterX = 478.0;
  const hv::FisheyeLensD front = makeFisheyeLens(c, false, cv::Size(1920, 960));
  const hv::FisheyeLensD back = makeFisheyeLens(c, true, cv::Size(1920, 960));
  EXPECT_DOUBLE_EQ(front.CenterX, 481.0);
  EXPECT_DOUBLE_EQ(back.CenterX, 960.0 + 478.0);
  EXPECT_DOUBLE_EQ(front.FocalLength, 470.0 / (95.0 * PiD / 180.0));
  c.FrontLensHalf = FrontHalf::Right;
  EXPECT_DOUBLE_EQ(makeFisheyeLens(c, false, cv::Size(1920, 960)).CenterX, 960.0 + 481.0);
  EXPECT_DOUBLE_EQ(makeFisheyeLens(c, true, cv::Size(1920, 960)).CenterX, 478.0);
  // Half size: x -> (x + 0.5) / 2 - 0.5.
  const hv::FisheyeLensD half = makeFisheyeLens(c, true, cv::Size(960, 480));
  EXPECT_DOUBLE_EQ(half.CenterX, (478.0 + 0.5) / 2.0 - 0.5);
  EXPECT_DOUBLE_EQ(half.CenterY, (479.5 + 0.5) / 2.0 - 0.5);
  EXPECT_DOUBLE_EQ(half.CircleRadius, 235.0);
  const std::string error =
    errorOf<std::invalid_argument>([&] { makeFisheyeLens(c, false, cv::Size(1920, 1080)); });
  EXPECT_NE(error.find("aspect ratio"), std::string::npos) << error;
}

// Orientation: the front lens looks along -Z with +X to the right of its image and +Y up;
// the back lens looks along +Z with -X to its right; a back yaw turns its axis about +Y.
TEST(FisheyeCalibration, LensOrientation)
{
  FisheyeCalibration c = presetCalibration("ricoh-theta");
  const cv::Size size(1920, 960);
  const hv::FisheyeLensD front = makeFisheyeLens(c, false, size);
  const hv::FisheyeLensD back = makeFisheyeLens(c, true, size);
  glm::dvec2 p;
  EXPECT_TRUE(hv::fisheyeProjectCamera(front, glm::dvec3(0, 0, -1), p));
  EXPECT_NEAR(p.x, front.CenterX, 1e-9);
  EXPECT_NEAR(p.y, front.CenterY, 1e-9);
  hv::fisheyeProjectCamera(front, glm::dvec3(1, 0, -1), p);
  EXPECT_GT(p.x, front.CenterX + 100.0);
  EXPECT_NEAR(p.y, front.CenterY, 1e-9);
  hv::fisheyeProjectCamera(front, glm::dvec3(0, 1, -1), p);
  EXPECT_LT(p.y, front.CenterY - 100.0); // up is towards row 0
  EXPECT_TRUE(hv::fisheyeProjectCamera(back, glm::dvec3(0, 0, 1), p));
  EXPECT_NEAR(p.x, back.CenterX, 1e-9);
  hv::fisheyeProjectCamera(back, glm::dvec3(-1, 0, 1), p);
  EXPECT_GT(p.x, back.CenterX + 100.0);
  hv::fisheyeProjectCamera(back, glm::dvec3(0, 1, 1), p);
  EXPECT_LT(p.y, back.CenterY - 100.0);

  // Yaw 5 degrees: Ry(185 deg) (0, 0, -1) = (sin 5 deg, 0, cos 5 deg) is the new axis.
  c.Back.YawDegrees = 5.0;
  const hv::FisheyeLensD yawed = makeFisheyeLens(c, true, size);
  const double a = 5.0 * PiD / 180.0;
  hv::fisheyeProjectCamera(yawed, glm::dvec3(std::sin(a), 0, std::cos(a)), p);
  EXPECT_NEAR(p.x, back.CenterX, 1e-9);
  EXPECT_NEAR(p.y, back.CenterY, 1e-9);
  // Pitch 3 degrees about +X tilts the front axis (0, 0, -1) to (0, sin 3, -cos 3).
  c.Front.PitchDegrees = 3.0;
  const hv::FisheyeLensD pitched = makeFisheyeLens(c, false, size);
  const double b = 3.0 * PiD / 180.0;
  hv::fisheyeProjectCamera(pitched, glm::dvec3(0, std::sin(b), -std::cos(b)), p);
  EXPECT_NEAR(p.x, front.CenterX, 1e-9);
  EXPECT_NEAR(p.y, front.CenterY, 1e-9);
  // Roll 90 degrees turns the image: +Y (up) now lands on the image's x axis.
  c.Front.PitchDegrees = 0.0;
  c.Front.RollDegrees = 90.0;
  const hv::FisheyeLensD rolled = makeFisheyeLens(c, false, size);
  hv::fisheyeProjectCamera(rolled, glm::dvec3(0, 1, -1), p);
  EXPECT_NEAR(std::abs(p.x - front.CenterX), 0.5 * PiD / 2.0 * front.FocalLength, 1e-6);
  EXPECT_NEAR(p.y, front.CenterY, 1e-9);
}

// The image circle of a rendered frame is found to within half a pixel, the vignetting of a
// rendered flat field to within 1 % of V over the circle.
TEST(FisheyeCalibration, CalibrationHelpersRecoverCircleAndVignetting)
{
  FisheyeCalibration c = presetCalibration("ricoh-theta");
  c.Front.CenterX = 483.2;
  c.Front.CenterY = 476.9;
  c.Front.Radius = 455.0;
  c.Back.Vignetting = { { -0.3, 0.05, -0.04 } };
  const cv::Mat flat(64, 128, CV_32FC3, cv::Scalar::all(0.6));
  const cv::Mat frame = renderDualFisheye(flat, c, cv::Size(1920, 960), 2);
  const ImageCircle circle = estimateImageCircle(frame, false);
  std::cout << "estimated circle (" << circle.CenterX << ", " << circle.CenterY << ") r "
            << circle.Radius << " vs (483.2, 476.9) r 455\n";
  EXPECT_NEAR(circle.CenterX, 483.2, 0.5);
  EXPECT_NEAR(circle.CenterY, 476.9, 0.5);
  EXPECT_NEAR(circle.Radius, 455.0, 0.5);
  const std::array<double, 3> fitted = fitVignetting(frame, c, true);
  FisheyeLensCalibration fittedLens = c.Back;
  fittedLens.Vignetting = fitted;
  for (int i = 0; i <= 20; ++i)
  {
    const double rho = 0.95 * i / 20.0;
    EXPECT_NEAR(vignettingFalloff(fittedLens, rho) / vignettingFalloff(c.Back, rho), 1.0, 0.01)
      << "rho " << rho;
  }
  EXPECT_THROW(
    estimateImageCircle(cv::Mat::zeros(960, 1920, CV_32FC3), true), std::invalid_argument);
  EXPECT_THROW(fitVignetting(cv::Mat::zeros(960, 1920, CV_8UC3), c, true), std::invalid_argument);
}
