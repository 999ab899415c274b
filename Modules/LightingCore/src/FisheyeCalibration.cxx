// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/FisheyeCalibration.h"

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace hv
{
namespace lighting
{
namespace
{
using Json = nlohmann::ordered_json;

constexpr double DegreesToRadians = 3.14159265358979323846 / 180.0;
constexpr double MaximumFieldOfViewDegrees = 250.0;

const char* const ProjectionNames[] = { "equidistant", "equisolid", "kannala-brandt" };

std::string lensKey(bool backLens)
{
  return backLens ? "lenses.back" : "lenses.front";
}

[[noreturn]] void fail(const std::string& key, const std::string& problem)
{
  throw std::invalid_argument("Fisheye calibration: '" + key + "' " + problem);
}

void requireFinite(double value, const std::string& key)
{
  if (!std::isfinite(value))
  {
    fail(key, "is not a finite number.");
  }
}

// ---- JSON reading with the key path in every error ----

std::string typeName(const Json& value)
{
  return value.type_name();
}

// Member `key` of `object` (at `path`), or nullptr when it is absent and optional.
const Json* member(const Json& object, const std::string& path, const char* key, bool required)
{
  const auto found = object.find(key);
  if (found == object.end())
  {
    if (required)
    {
      fail(path.empty() ? key : path + "." + key,
        "is missing; see Documentation/FisheyeCalibration.md for the file format.");
    }
    return nullptr;
  }
  return &*found;
}

std::string join(const std::string& path, const char* key)
{
  return path.empty() ? std::string(key) : path + "." + key;
}

// Rejects keys the schema does not know, so that a misspelt optional key is not silently
// replaced by its default.
void rejectUnknownKeys(
  const Json& object, const std::string& path, std::initializer_list<const char*> known)
{
  for (auto it = object.begin(); it != object.end(); ++it)
  {
    const bool isKnown =
      std::any_of(known.begin(), known.end(), [&](const char* name) { return it.key() == name; });
    if (!isKnown)
    {
      std::string list;
      for (const char* name : known)
      {
        list += (list.empty() ? "" : ", ") + std::string(name);
      }
      fail(join(path, it.key().c_str()), "is not a known key here (known: " + list + ").");
    }
  }
}

const Json& requireObject(const Json& object, const std::string& path, const char* key)
{
  const Json& value = *member(object, path, key, true);
  if (!value.is_object())
  {
    fail(join(path, key), "must be a JSON object, not " + typeName(value) + ".");
  }
  return value;
}

double readNumber(
  const Json& object, const std::string& path, const char* key, bool required, double fallback)
{
  const Json* value = member(object, path, key, required);
  if (!value)
  {
    return fallback;
  }
  if (!value->is_number())
  {
    fail(join(path, key), "must be a number, not " + typeName(*value) + ".");
  }
  return value->get<double>();
}

int readInteger(const Json& object, const std::string& path, const char* key)
{
  const Json& value = *member(object, path, key, true);
  if (!value.is_number_integer())
  {
    fail(join(path, key), "must be an integer, not " + typeName(value) + ".");
  }
  return value.get<int>();
}

bool readBoolean(const Json& object, const std::string& path, const char* key, bool fallback)
{
  const Json* value = member(object, path, key, false);
  if (!value)
  {
    return fallback;
  }
  if (!value->is_boolean())
  {
    fail(join(path, key), "must be true or false, not " + typeName(*value) + ".");
  }
  return value->get<bool>();
}

std::string readString(const Json& object, const std::string& path, const char* key, bool required,
  const std::string& fallback)
{
  const Json* value = member(object, path, key, required);
  if (!value)
  {
    return fallback;
  }
  if (!value->is_string())
  {
    fail(join(path, key), "must be a string, not " + typeName(*value) + ".");
  }
  return value->get<std::string>();
}

template <std::size_t N>
std::array<double, N> readArray(const Json& object, const std::string& path, const char* key,
  bool required, const std::array<double, N>& fallback)
{
  const Json* value = member(object, path, key, required);
  if (!value)
  {
    return fallback;
  }
  if (!value->is_array() || value->size() != N)
  {
    fail(join(path, key),
      "must be an array of " + std::to_string(N) + " numbers, not " +
        (value->is_array() ? "an array of " + std::to_string(value->size()) : typeName(*value)) +
        ".");
  }
  std::array<double, N> result{};
  for (std::size_t i = 0; i < N; ++i)
  {
    if (!(*value)[i].is_number())
    {
      fail(join(path, key) + "[" + std::to_string(i) + "]",
        "must be a number, not " + typeName((*value)[i]) + ".");
    }
    result[i] = (*value)[i].get<double>();
  }
  return result;
}

FisheyeProjection readProjection(const Json& object, const std::string& path)
{
  const std::string name = readString(object, path, "model", true, "");
  for (int i = 0; i < 3; ++i)
  {
    if (name == ProjectionNames[i])
    {
      return static_cast<FisheyeProjection>(i);
    }
  }
  fail(join(path, "model"),
    "is '" + name + "'; use \"equidistant\", \"equisolid\" or \"kannala-brandt\".");
}

FisheyeLensCalibration readLens(const Json& lenses, bool backLens)
{
  const std::string path = lensKey(backLens);
  const Json& object = requireObject(lenses, "lenses", backLens ? "back" : "front");
  rejectUnknownKeys(object, path,
    { "model", "center", "radius", "fieldOfViewDegrees", "focalLength", "kannalaBrandt",
      "vignetting", "exposureGain", "whiteBalance", "rotationDegrees" });
  FisheyeLensCalibration lens;
  lens.Model = readProjection(object, path);
  const auto center = readArray<2>(object, path, "center", true, {});
  lens.CenterX = center[0];
  lens.CenterY = center[1];
  lens.Radius = readNumber(object, path, "radius", true, 0.0);
  lens.FieldOfViewDegrees = readNumber(object, path, "fieldOfViewDegrees", true, 0.0);
  lens.FocalLength = readNumber(object, path, "focalLength", false, lens.FocalLength);
  lens.KannalaBrandt = readArray<4>(object, path, "kannalaBrandt", false, lens.KannalaBrandt);
  lens.Vignetting = readArray<3>(object, path, "vignetting", false, lens.Vignetting);
  lens.ExposureGain = readNumber(object, path, "exposureGain", false, lens.ExposureGain);
  lens.WhiteBalance = readArray<3>(object, path, "whiteBalance", false, lens.WhiteBalance);
  if (const Json* rotation = member(object, path, "rotationDegrees", false))
  {
    const std::string rotationPath = path + ".rotationDegrees";
    if (!rotation->is_object())
    {
      fail(rotationPath, "must be a JSON object {\"yaw\", \"pitch\", \"roll\"}.");
    }
    rejectUnknownKeys(*rotation, rotationPath, { "yaw", "pitch", "roll" });
    lens.YawDegrees = readNumber(*rotation, rotationPath, "yaw", false, 0.0);
    lens.PitchDegrees = readNumber(*rotation, rotationPath, "pitch", false, 0.0);
    lens.RollDegrees = readNumber(*rotation, rotationPath, "roll", false, 0.0);
  }
  return lens;
}

Json writeLens(const FisheyeLensCalibration& lens)
{
  Json object;
  object["model"] = ProjectionNames[static_cast<int>(lens.Model)];
  object["center"] = { lens.CenterX, lens.CenterY };
  object["radius"] = lens.Radius;
  object["fieldOfViewDegrees"] = lens.FieldOfViewDegrees;
  object["focalLength"] = lens.FocalLength;
  object["kannalaBrandt"] = lens.KannalaBrandt;
  object["vignetting"] = lens.Vignetting;
  object["exposureGain"] = lens.ExposureGain;
  object["whiteBalance"] = lens.WhiteBalance;
  object["rotationDegrees"] = {
    { "yaw", lens.YawDegrees },
    { "pitch", lens.PitchDegrees },
    { "roll", lens.RollDegrees },
  };
  return object;
}

// ---- validation ----

void validateLens(
  const FisheyeLensCalibration& lens, bool backLens, int frameWidth, int frameHeight)
{
  const std::string path = lensKey(backLens);
  requireFinite(lens.CenterX, path + ".center[0]");
  requireFinite(lens.CenterY, path + ".center[1]");
  requireFinite(lens.Radius, path + ".radius");
  requireFinite(lens.FieldOfViewDegrees, path + ".fieldOfViewDegrees");
  requireFinite(lens.FocalLength, path + ".focalLength");
  if (!(lens.FieldOfViewDegrees > 0.0 && lens.FieldOfViewDegrees <= MaximumFieldOfViewDegrees))
  {
    fail(path + ".fieldOfViewDegrees",
      "= " + std::to_string(lens.FieldOfViewDegrees) +
        " is outside (0, 250] degrees; dual-fisheye lenses see 180 to 220 degrees each "
        "(190-200 is typical).");
  }
  if (!(lens.Radius > 0.0))
  {
    fail(path + ".radius", "must be positive: the image circle radius in pixels.");
  }
  if (lens.CenterX < 0.0 || lens.CenterX > 0.5 * frameWidth || lens.CenterY < 0.0 ||
    lens.CenterY > frameHeight)
  {
    fail(path + ".center",
      "lies outside the lens's half of the " + std::to_string(frameWidth) + "x" +
        std::to_string(frameHeight) +
        " frame; centres are measured from the top-left corner of the lens's own half.");
  }
  if (lens.FocalLength < 0.0)
  {
    fail(
      path + ".focalLength", "must be positive, or 0 to derive it from radius and field of view.");
  }
  for (std::size_t i = 0; i < 4; ++i)
  {
    requireFinite(lens.KannalaBrandt[i], path + ".kannalaBrandt[" + std::to_string(i) + "]");
  }
  if (lens.Model == FisheyeProjection::KannalaBrandt)
  {
    // Newton's inversion (hv::fisheyeTheta) needs theta_d(theta) to increase over the field.
    const double maxTheta = 0.5 * lens.FieldOfViewDegrees * DegreesToRadians;
    for (int i = 0; i <= 256; ++i)
    {
      const double theta = maxTheta * i / 256.0;
      if (!(kannalaBrandtDistortedAngleDerivative(lens.KannalaBrandt.data(), theta) > 0.0))
      {
        fail(path + ".kannalaBrandt",
          "gives a projection theta_d(theta) that stops increasing at theta = " +
            std::to_string(theta / DegreesToRadians) +
            " degrees, inside the field of view; re-run the calibration or reduce "
            "fieldOfViewDegrees.");
      }
    }
  }
  for (std::size_t i = 0; i < 3; ++i)
  {
    requireFinite(lens.Vignetting[i], path + ".vignetting[" + std::to_string(i) + "]");
  }
  for (int i = 0; i <= 100; ++i)
  {
    if (!(vignettingFalloff(lens, i / 100.0) >= 0.05))
    {
      fail(path + ".vignetting",
        "gives a falloff V(rho) below 0.05 at rho = " + std::to_string(i / 100.0) +
          "; V must stay positive over the image circle (see the vignetting fit in "
          "Documentation/FisheyeCalibration.md).");
    }
  }
  requireFinite(lens.ExposureGain, path + ".exposureGain");
  if (!(lens.ExposureGain > 0.0))
  {
    fail(path + ".exposureGain", "must be positive.");
  }
  for (std::size_t i = 0; i < 3; ++i)
  {
    const std::string key = path + ".whiteBalance[" + std::to_string(i) + "]";
    requireFinite(lens.WhiteBalance[i], key);
    if (!(lens.WhiteBalance[i] > 0.0))
    {
      fail(key, "must be positive.");
    }
  }
  const double angles[3] = { lens.YawDegrees, lens.PitchDegrees, lens.RollDegrees };
  const char* names[3] = { "yaw", "pitch", "roll" };
  for (int i = 0; i < 3; ++i)
  {
    const std::string key = path + ".rotationDegrees." + names[i];
    requireFinite(angles[i], key);
    if (std::abs(angles[i]) > 180.0)
    {
      fail(key, "must lie in [-180, 180] degrees.");
    }
  }
}

glm::dmat3 fromRows(double a00, double a01, double a02, double a10, double a11, double a12,
  double a20, double a21, double a22)
{
  // glm's constructor takes columns; the rotation formulas below are written by rows.
  return glm::transpose(glm::dmat3(a00, a01, a02, a10, a11, a12, a20, a21, a22));
}

glm::dmat3 rotationX(double angle)
{
  const double c = std::cos(angle), s = std::sin(angle);
  return fromRows(1, 0, 0, 0, c, -s, 0, s, c);
}

glm::dmat3 rotationY(double angle)
{
  const double c = std::cos(angle), s = std::sin(angle);
  return fromRows(c, 0, s, 0, 1, 0, -s, 0, c);
}

glm::dmat3 rotationZ(double angle)
{
  const double c = std::cos(angle), s = std::sin(angle);
  return fromRows(c, -s, 0, s, c, 0, 0, 0, 1);
}

FisheyeCalibration makePreset(const std::string& name)
{
  FisheyeCalibration calibration;
  calibration.CameraName = name;
  if (name == "insta360-one-x")
  {
    // Insta360 ONE X-like: two ~200-degree lenses, 3040x1520 side-by-side dual-fisheye
    // frames (the preview/stream resolution), circles nearly filling each 1520x1520 half.
    calibration.Notes = "Nominal values for an Insta360 ONE X-like camera (3040x1520 "
                        "dual-fisheye frames, about 200 degrees per lens). Refine them with "
                        "the procedure in Documentation/FisheyeCalibration.md.";
    calibration.FrameWidth = 3040;
    calibration.FrameHeight = 1520;
    for (FisheyeLensCalibration* lens : { &calibration.Front, &calibration.Back })
    {
      lens->Model = FisheyeProjection::Equidistant;
      lens->CenterX = 759.5;
      lens->CenterY = 759.5;
      lens->Radius = 750.0;
      lens->FieldOfViewDegrees = 200.0;
    }
    calibration.Stitching.BlendBandDegrees = 10.0;
  }
  else if (name == "ricoh-theta")
  {
    // Ricoh Theta S/V-like: two ~190-degree lenses, 1920x960 side-by-side dual-fisheye
    // frames, circles of about 0.98 of each 960x960 half.
    calibration.Notes = "Nominal values for a Ricoh Theta S/V-like camera (1920x960 "
                        "dual-fisheye frames, about 190 degrees per lens). Some models and "
                        "modes rotate the circles by 90 degrees (set rotationDegrees.roll). "
                        "Refine with the procedure in Documentation/FisheyeCalibration.md.";
    calibration.FrameWidth = 1920;
    calibration.FrameHeight = 960;
    for (FisheyeLensCalibration* lens : { &calibration.Front, &calibration.Back })
    {
      lens->Model = FisheyeProjection::Equidistant;
      lens->CenterX = 479.5;
      lens->CenterY = 479.5;
      lens->Radius = 470.0;
      lens->FieldOfViewDegrees = 190.0;
    }
    calibration.Stitching.BlendBandDegrees = 6.0;
  }
  else
  {
    std::string names;
    for (const std::string& known : calibrationPresetNames())
    {
      names += (names.empty() ? "'" : ", '") + known + "'";
    }
    throw std::invalid_argument("Unknown fisheye calibration preset '" + name +
      "'; the presets are " + names + ", or load a calibration file.");
  }
  return calibration;
}
}

bool FisheyeLensCalibration::operator==(const FisheyeLensCalibration& other) const
{
  return this->Model == other.Model && this->CenterX == other.CenterX &&
    this->CenterY == other.CenterY && this->Radius == other.Radius &&
    this->FieldOfViewDegrees == other.FieldOfViewDegrees &&
    this->FocalLength == other.FocalLength && this->KannalaBrandt == other.KannalaBrandt &&
    this->Vignetting == other.Vignetting && this->ExposureGain == other.ExposureGain &&
    this->WhiteBalance == other.WhiteBalance && this->YawDegrees == other.YawDegrees &&
    this->PitchDegrees == other.PitchDegrees && this->RollDegrees == other.RollDegrees;
}

bool StitchingOptions::operator==(const StitchingOptions& other) const
{
  return this->BlendBandDegrees == other.BlendBandDegrees &&
    this->AutomaticGainMatching == other.AutomaticGainMatching &&
    this->GainSmoothing == other.GainSmoothing;
}

bool FisheyeCalibration::operator==(const FisheyeCalibration& other) const
{
  return this->CameraName == other.CameraName && this->Notes == other.Notes &&
    this->FrameWidth == other.FrameWidth && this->FrameHeight == other.FrameHeight &&
    this->FrontLensHalf == other.FrontLensHalf && this->Front == other.Front &&
    this->Back == other.Back && this->Stitching == other.Stitching;
}

double vignettingFalloff(const FisheyeLensCalibration& lens, double rho)
{
  const double r2 = rho * rho;
  return 1.0 + r2 * (lens.Vignetting[0] + r2 * (lens.Vignetting[1] + r2 * lens.Vignetting[2]));
}

void validateCalibration(const FisheyeCalibration& calibration)
{
  if (calibration.FrameWidth <= 0 || calibration.FrameHeight <= 0)
  {
    fail("frame.width",
      "and 'frame.height' must be positive (the frame size in pixels at which "
      "centres and radii were measured).");
  }
  if (calibration.FrameWidth % 2 != 0)
  {
    fail("frame.width", "must be even: a side-by-side frame holds one lens per half.");
  }
  validateLens(calibration.Front, false, calibration.FrameWidth, calibration.FrameHeight);
  validateLens(calibration.Back, true, calibration.FrameWidth, calibration.FrameHeight);
  const StitchingOptions& stitching = calibration.Stitching;
  requireFinite(stitching.BlendBandDegrees, "stitching.blendBandDegrees");
  if (stitching.BlendBandDegrees < 0.0 || stitching.BlendBandDegrees > 90.0)
  {
    fail("stitching.blendBandDegrees", "must lie in [0, 90] degrees.");
  }
  requireFinite(stitching.GainSmoothing, "stitching.gainSmoothing");
  if (stitching.GainSmoothing < 0.0 || stitching.GainSmoothing >= 1.0)
  {
    fail("stitching.gainSmoothing", "must lie in [0, 1): 0 = no temporal smoothing.");
  }
}

std::string toJson(const FisheyeCalibration& calibration)
{
  Json root;
  root["schemaVersion"] = FisheyeCalibration::SchemaVersion;
  root["camera"] = calibration.CameraName;
  root["notes"] = calibration.Notes;
  root["frame"] = {
    { "width", calibration.FrameWidth },
    { "height", calibration.FrameHeight },
    { "layout", "side-by-side" },
    { "frontHalf", calibration.FrontLensHalf == FrontHalf::Left ? "left" : "right" },
  };
  root["lenses"] = {
    { "front", writeLens(calibration.Front) },
    { "back", writeLens(calibration.Back) },
  };
  root["stitching"] = {
    { "blendBandDegrees", calibration.Stitching.BlendBandDegrees },
    { "automaticGainMatching", calibration.Stitching.AutomaticGainMatching },
    { "gainSmoothing", calibration.Stitching.GainSmoothing },
  };
  // nlohmann-json prints doubles with the shortest representation that reads back to the
  // same value, so save -> load is exact.
  return root.dump(2) + "\n";
}

FisheyeCalibration fromJson(const std::string& text)
{
  Json root;
  try
  {
    root = Json::parse(text);
  }
  catch (const Json::parse_error& error)
  {
    throw std::runtime_error(
      std::string("Fisheye calibration is not valid JSON: ") + error.what() + ".");
  }
  if (!root.is_object())
  {
    throw std::invalid_argument("Fisheye calibration must be a JSON object with the keys "
                                "'schemaVersion', 'frame', 'lenses' (and optionally "
                                "'stitching'), not " +
      typeName(root) + ".");
  }
  rejectUnknownKeys(
    root, "", { "schemaVersion", "camera", "notes", "frame", "lenses", "stitching" });
  const int version = readInteger(root, "", "schemaVersion");
  if (version < 1 || version > FisheyeCalibration::SchemaVersion)
  {
    fail("schemaVersion",
      "is " + std::to_string(version) + "; this HoloVolume reads version " +
        std::to_string(FisheyeCalibration::SchemaVersion) +
        " (a newer file needs a newer HoloVolume).");
  }
  FisheyeCalibration calibration;
  calibration.CameraName = readString(root, "", "camera", false, "");
  calibration.Notes = readString(root, "", "notes", false, "");

  const Json& frame = requireObject(root, "", "frame");
  rejectUnknownKeys(frame, "frame", { "width", "height", "layout", "frontHalf" });
  calibration.FrameWidth = readInteger(frame, "frame", "width");
  calibration.FrameHeight = readInteger(frame, "frame", "height");
  const std::string layout = readString(frame, "frame", "layout", false, "side-by-side");
  if (layout != "side-by-side")
  {
    fail("frame.layout", "is '" + layout + "'; only \"side-by-side\" frames are supported.");
  }
  const std::string half = readString(frame, "frame", "frontHalf", false, "left");
  if (half != "left" && half != "right")
  {
    fail("frame.frontHalf", "is '" + half + "'; use \"left\" or \"right\".");
  }
  calibration.FrontLensHalf = half == "left" ? FrontHalf::Left : FrontHalf::Right;

  const Json& lenses = requireObject(root, "", "lenses");
  rejectUnknownKeys(lenses, "lenses", { "front", "back" });
  calibration.Front = readLens(lenses, false);
  calibration.Back = readLens(lenses, true);

  if (const Json* stitching = member(root, "", "stitching", false))
  {
    if (!stitching->is_object())
    {
      fail("stitching", "must be a JSON object.");
    }
    rejectUnknownKeys(
      *stitching, "stitching", { "blendBandDegrees", "automaticGainMatching", "gainSmoothing" });
    StitchingOptions& options = calibration.Stitching;
    options.BlendBandDegrees =
      readNumber(*stitching, "stitching", "blendBandDegrees", false, options.BlendBandDegrees);
    options.AutomaticGainMatching =
      readBoolean(*stitching, "stitching", "automaticGainMatching", options.AutomaticGainMatching);
    options.GainSmoothing =
      readNumber(*stitching, "stitching", "gainSmoothing", false, options.GainSmoothing);
  }
  validateCalibration(calibration);
  return calibration;
}

FisheyeCalibration loadCalibration(const std::string& path)
{
  std::ifstream file(path);
  if (!file)
  {
    throw std::runtime_error("Cannot open the fisheye calibration file '" + path +
      "'; check the path, or use a preset (" + calibrationPresetNames().front() + ", ...).");
  }
  std::stringstream text;
  text << file.rdbuf();
  try
  {
    return fromJson(text.str());
  }
  catch (const std::invalid_argument& error)
  {
    throw std::invalid_argument("'" + path + "': " + error.what());
  }
  catch (const std::runtime_error& error)
  {
    throw std::runtime_error("'" + path + "': " + error.what());
  }
}

void saveCalibration(const FisheyeCalibration& calibration, const std::string& path)
{
  validateCalibration(calibration);
  std::ofstream file(path);
  if (!file)
  {
    throw std::runtime_error("Cannot write the fisheye calibration file '" + path +
      "'; check that the folder exists and is writable.");
  }
  file << toJson(calibration);
  if (!file.flush())
  {
    throw std::runtime_error("Writing the fisheye calibration file '" + path + "' failed.");
  }
}

std::vector<std::string> calibrationPresetNames()
{
  return { "insta360-one-x", "ricoh-theta" };
}

FisheyeCalibration presetCalibration(const std::string& name)
{
  return makePreset(name);
}

FisheyeLensD makeFisheyeLens(
  const FisheyeCalibration& calibration, bool backLens, const cv::Size& frameSize)
{
  validateCalibration(calibration);
  if (frameSize.width <= 0 || frameSize.height <= 0)
  {
    throw std::invalid_argument("Fisheye lens: the frame size must be positive.");
  }
  const double scaleX = static_cast<double>(frameSize.width) / calibration.FrameWidth;
  const double scaleY = static_cast<double>(frameSize.height) / calibration.FrameHeight;
  // Reduced frames are rounded to whole pixels; 2 % also accepts 1-pixel rounding of small
  // frames, while a 16:9 frame for a 2:1 calibration (12 %) is rejected.
  if (std::abs(scaleX / scaleY - 1.0) > 0.02)
  {
    throw std::invalid_argument("The frame is " + std::to_string(frameSize.width) + "x" +
      std::to_string(frameSize.height) + " but the fisheye calibration is for " +
      std::to_string(calibration.FrameWidth) + "x" + std::to_string(calibration.FrameHeight) +
      " frames: the aspect ratio differs. Use the camera's dual-fisheye output (side by side, " +
      "usually 2:1) or a calibration made for this frame size.");
  }
  const FisheyeLensCalibration& source = backLens ? calibration.Back : calibration.Front;
  const bool inRightHalf = backLens == (calibration.FrontLensHalf == FrontHalf::Left);
  const double halfOffset = inRightHalf ? 0.5 * calibration.FrameWidth : 0.0;
  const double scale = 0.5 * (scaleX + scaleY);

  FisheyeLensD lens;
  lens.Projection = source.Model;
  // Pixel centres sit at integers: position x covers [x - 0.5, x + 0.5], so resizing maps
  // x to (x + 0.5) s - 0.5.
  lens.CenterX = (source.CenterX + halfOffset + 0.5) * scaleX - 0.5;
  lens.CenterY = (source.CenterY + 0.5) * scaleY - 0.5;
  lens.MaxTheta = 0.5 * source.FieldOfViewDegrees * DegreesToRadians;
  for (int i = 0; i < 4; ++i)
  {
    lens.K[i] = source.KannalaBrandt[i];
  }
  lens.CircleRadius = source.Radius * scale;
  if (source.Model == FisheyeProjection::KannalaBrandt && source.FocalLength > 0.0)
  {
    lens.FocalLength = source.FocalLength * scale;
  }
  else
  {
    lens.FocalLength =
      lens.CircleRadius / fisheyeNormalizedRadius(source.Model, lens.K, lens.MaxTheta);
  }
  const double nominalYaw = backLens ? 180.0 : 0.0;
  const glm::dmat3 lensToCamera = rotationY((nominalYaw + source.YawDegrees) * DegreesToRadians) *
    rotationX(source.PitchDegrees * DegreesToRadians) *
    rotationZ(source.RollDegrees * DegreesToRadians) * fromRows(1, 0, 0, 0, -1, 0, 0, 0, -1);
  lens.CameraToLens = glm::transpose(lensToCamera);
  return lens;
}

ImageCircle estimateImageCircle(const cv::Mat& frame, bool rightHalf)
{
  if (frame.empty() || frame.channels() != 3 ||
    (frame.depth() != CV_8U && frame.depth() != CV_16U && frame.depth() != CV_32F))
  {
    throw std::invalid_argument("estimateImageCircle: pass a CV_8UC3, CV_16UC3 or CV_32FC3 "
                                "dual-fisheye frame.");
  }
  const int halfWidth = frame.cols / 2;
  const cv::Mat half = frame(cv::Rect(rightHalf ? halfWidth : 0, 0, halfWidth, frame.rows));
  cv::Mat grey;
  cv::cvtColor(half, grey, cv::COLOR_RGB2GRAY);
  cv::Mat grey8;
  double maximum = 0.0;
  cv::minMaxLoc(grey, nullptr, &maximum);
  if (!(maximum > 0.0))
  {
    throw std::invalid_argument("estimateImageCircle: the frame half is black; photograph a "
                                "bright, evenly lit scene.");
  }
  grey.convertTo(grey8, CV_8U, 255.0 / maximum);
  // Otsu's threshold separates the lit disk from the dark surround without a tuned level.
  cv::Mat disk;
  cv::threshold(grey8, disk, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  cv::morphologyEx(
    disk, disk, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(5, 5)));
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(disk, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  const auto largest = std::max_element(contours.begin(), contours.end(),
    [](const auto& a, const auto& b) { return cv::contourArea(a) < cv::contourArea(b); });
  if (largest == contours.end() || largest->size() < 20 ||
    cv::contourArea(*largest) < 0.05 * half.total())
  {
    throw std::invalid_argument("estimateImageCircle: no image circle found in the " +
      std::string(rightHalf ? "right" : "left") +
      " half; photograph a bright, evenly lit scene that fills the lens.");
  }
  // A least-squares ellipse through the outline; an outline touching the frame edge is cut
  // straight, so only points away from the border are used.
  std::vector<cv::Point2f> outline;
  for (const cv::Point& p : *largest)
  {
    if (p.x > 1 && p.y > 1 && p.x < half.cols - 2 && p.y < half.rows - 2)
    {
      outline.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
    }
  }
  if (outline.size() < 20)
  {
    throw std::invalid_argument(
      "estimateImageCircle: the lit area fills the frame half; its circle cannot be found.");
  }
  const cv::RotatedRect ellipse = cv::fitEllipse(outline);
  ImageCircle circle;
  circle.CenterX = ellipse.center.x;
  circle.CenterY = ellipse.center.y;
  // The outline runs along the outermost lit pixel centres, half a pixel inside the edge.
  circle.Radius = 0.25 * (ellipse.size.width + ellipse.size.height) + 0.5;
  return circle;
}

std::array<double, 3> fitVignetting(const cv::Mat& linearFrame,
  const FisheyeCalibration& calibration, bool backLens, double maxRho, double saturationLevel)
{
  if (linearFrame.type() != CV_32FC3)
  {
    throw std::invalid_argument("fitVignetting: pass the flat-field frame as linear CV_32FC3 "
                                "(linearise it with the camera response first).");
  }
  const FisheyeLensD lens = makeFisheyeLens(calibration, backLens, linearFrame.size());
  // Least squares for y(rho) = y0 + b1 rho^2 + b2 rho^4 + b3 rho^6 (linear in the unknowns),
  // then a_i = b_i / y0 so that V(0) = 1.
  cv::Mat normal = cv::Mat::zeros(4, 4, CV_64F);
  cv::Mat rhs = cv::Mat::zeros(4, 1, CV_64F);
  int used = 0;
  const int x0 = std::max(0, static_cast<int>(lens.CenterX - lens.CircleRadius));
  const int x1 = std::min(linearFrame.cols - 1, static_cast<int>(lens.CenterX + lens.CircleRadius));
  const int y0 = std::max(0, static_cast<int>(lens.CenterY - lens.CircleRadius));
  const int y1 = std::min(linearFrame.rows - 1, static_cast<int>(lens.CenterY + lens.CircleRadius));
  for (int y = y0; y <= y1; ++y)
  {
    const cv::Vec3f* row = linearFrame.ptr<cv::Vec3f>(y);
    for (int x = x0; x <= x1; ++x)
    {
      const double rho = std::hypot(x - lens.CenterX, y - lens.CenterY) / lens.CircleRadius;
      const cv::Vec3f& p = row[x];
      if (rho > maxRho || std::max({ p[0], p[1], p[2] }) >= saturationLevel)
      {
        continue;
      }
      const double value = luminance(glm::vec3(p[0], p[1], p[2]));
      const double r2 = rho * rho;
      const double basis[4] = { 1.0, r2, r2 * r2, r2 * r2 * r2 };
      for (int i = 0; i < 4; ++i)
      {
        rhs.at<double>(i) += basis[i] * value;
        for (int j = 0; j < 4; ++j)
        {
          normal.at<double>(i, j) += basis[i] * basis[j];
        }
      }
      ++used;
    }
  }
  cv::Mat solution;
  if (used < 100 || !cv::solve(normal, rhs, solution, cv::DECOMP_SVD) ||
    !(solution.at<double>(0) > 0.0))
  {
    throw std::invalid_argument("fitVignetting: too few usable pixels in the " +
      std::string(backLens ? "back" : "front") +
      " lens's circle; photograph a uniformly lit diffuser that fills the lens, exposed so that "
      "its centre is below saturation.");
  }
  const double y0fit = solution.at<double>(0);
  return { { solution.at<double>(1) / y0fit, solution.at<double>(2) / y0fit,
    solution.at<double>(3) / y0fit } };
}
}
}
