// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/remoting/Protocol.h"

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat4x4.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>

namespace hv
{
namespace remoting
{
using nlohmann::json;

namespace
{
// Integer fields sent as JSON numbers: converting a value outside the C++ type's range is
// undefined behaviour (the fuzzer found a welcome with eyeHeight = 3.2e83), so parsers check
// it first.
struct CountRange
{
  double limit; // exclusive
  const char* maximum;
};
constexpr CountRange IntRange = { 2147483648.0, "2^31 - 1" };
constexpr CountRange CounterRange = { 18446744073709551616.0, "2^64 - 1" };

bool FitsCount(double value, const CountRange& range)
{
  return value >= 0.0 && value < range.limit;
}

// The parser must never throw (it runs on the network thread and under libFuzzer), so every
// access checks the type first and nlohmann's throwing accessors are not used.
class FieldReader
{
public:
  FieldReader(const json& object, const char* context, std::string* reason)
    : Object(object)
    , Context(context)
    , Reason(reason)
  {
  }

  bool Fail(const std::string& what) const
  {
    if (this->Reason)
    {
      *this->Reason = std::string(this->Context) + ": " + what;
    }
    return false;
  }

  const json* Find(const char* name) const
  {
    const auto it = this->Object.find(name);
    return it == this->Object.end() ? nullptr : &*it;
  }

  bool Has(const char* name) const { return this->Find(name) != nullptr; }

  bool Number(const char* name, double* value) const
  {
    const json* field = this->Find(name);
    if (!field || !field->is_number())
    {
      return this->Fail(std::string("'") + name + "' must be a number");
    }
    *value = field->get<double>();
    if (!std::isfinite(*value))
    {
      return this->Fail(std::string("'") + name + "' must be finite");
    }
    return true;
  }

  bool Counter(const char* name, std::uint64_t* value) const
  {
    const json* field = this->Find(name);
    if (!field || !(field->is_number_unsigned() || field->is_number_integer()) ||
      (field->is_number_integer() && field->get<std::int64_t>() < 0))
    {
      return this->Fail(std::string("'") + name + "' must be an integer >= 0");
    }
    *value = field->get<std::uint64_t>();
    return true;
  }

  bool String(const char* name, std::string* value, std::size_t maximumLength = 64) const
  {
    const json* field = this->Find(name);
    if (!field || !field->is_string())
    {
      return this->Fail(std::string("'") + name + "' must be a string");
    }
    const auto& text = field->get_ref<const std::string&>();
    if (text.size() > maximumLength)
    {
      return this->Fail(std::string("'") + name + "' is longer than " +
        std::to_string(maximumLength) + " characters");
    }
    *value = text;
    return true;
  }

  bool Boolean(const char* name, bool* value) const
  {
    const json* field = this->Find(name);
    if (!field || !field->is_boolean())
    {
      return this->Fail(std::string("'") + name + "' must be true or false");
    }
    *value = field->get<bool>();
    return true;
  }

  template <std::size_t N>
  bool Numbers(const json* field, const std::string& name, std::array<double, N>* values) const
  {
    if (!field || !field->is_array() || field->size() != N)
    {
      return this->Fail("'" + name + "' must hold " + std::to_string(N) + " numbers");
    }
    for (std::size_t i = 0; i < N; ++i)
    {
      const json& element = (*field)[i];
      if (!element.is_number() || !std::isfinite(element.get<double>()))
      {
        return this->Fail("'" + name + "' must hold " + std::to_string(N) + " finite numbers");
      }
      (*values)[i] = element.get<double>();
    }
    return true;
  }

  template <std::size_t N>
  bool Numbers(const char* name, std::array<double, N>* values) const
  {
    return this->Numbers(this->Find(name), name, values);
  }

  // A view or projection matrix must be invertible: the renderer unprojects through it.
  bool InvertibleMatrix(const json* field, const std::string& name, Matrix4* matrix) const
  {
    if (!this->Numbers(field, name, matrix))
    {
      return false;
    }
    Matrix4 inverse;
    if (!Invert(*matrix, &inverse))
    {
      return this->Fail("'" + name + "' is not invertible");
    }
    return true;
  }

private:
  const json& Object;
  const char* Context;
  std::string* Reason;
};

bool WithinDepth(std::string_view text)
{
  int depth = 0;
  bool inString = false;
  for (std::size_t i = 0; i < text.size(); ++i)
  {
    const char c = text[i];
    if (inString)
    {
      if (c == '\\')
      {
        ++i;
      }
      else if (c == '"')
      {
        inString = false;
      }
    }
    else if (c == '"')
    {
      inString = true;
    }
    else if (c == '[' || c == '{')
    {
      if (++depth > MaximumJsonDepth)
      {
        return false;
      }
    }
    else if (c == ']' || c == '}')
    {
      --depth;
    }
  }
  return true;
}

bool ParseHello(const FieldReader& fields, HelloMessage* hello)
{
  double protocol = 0.0;
  if (!fields.Number("protocol", &protocol))
  {
    return false;
  }
  hello->protocol = protocol >= 0.0 && protocol < 1e6 ? static_cast<int>(protocol) : -1;
  std::string role = "controller";
  if (fields.Has("role") && !fields.String("role", &role))
  {
    return false;
  }
  if (role == "controller")
  {
    hello->role = Role::Controller;
  }
  else if (role == "spectator")
  {
    hello->role = Role::Spectator;
  }
  else
  {
    return fields.Fail("'role' must be \"controller\" or \"spectator\"");
  }
  if (fields.Has("client") && !fields.String("client", &hello->client, 128))
  {
    return false;
  }
  hello->decodesH264 = false;
  if (const json* codecs = fields.Find("codecs"))
  {
    if (!codecs->is_array() || codecs->size() > 16)
    {
      return fields.Fail("'codecs' must be a list of codec names");
    }
    for (const json& codec : *codecs)
    {
      if (!codec.is_string())
      {
        return fields.Fail("'codecs' must be a list of codec names");
      }
      hello->decodesH264 = hello->decodesH264 || codec.get_ref<const std::string&>() == "h264";
    }
  }
  return true;
}

bool ParsePose(const FieldReader& fields, PoseMessage* pose)
{
  if (!fields.Counter("poseId", &pose->poseId) ||
    !fields.InvertibleMatrix(fields.Find("head"), "head", &pose->head))
  {
    return false;
  }
  pose->mode.clear();
  if (fields.Has("mode") && !fields.String("mode", &pose->mode))
  {
    return false;
  }
  const json* views = fields.Find("views");
  if (!views || !views->is_array() || views->size() != 2)
  {
    return fields.Fail("'views' must hold two entries, left and right");
  }
  bool seen[2] = { false, false };
  for (const json& view : *views)
  {
    if (!view.is_object())
    {
      return fields.Fail("each entry of 'views' must be an object");
    }
    const FieldReader viewFields(view, "pose", nullptr);
    std::string eyeName;
    const json* eye = viewFields.Find("eye");
    if (!eye || !eye->is_string())
    {
      return fields.Fail("each view needs 'eye': \"left\" or \"right\"");
    }
    eyeName = eye->get<std::string>();
    const int index = eyeName == "left" ? 0 : eyeName == "right" ? 1 : -1;
    if (index < 0 || seen[index])
    {
      return fields.Fail("'views' must hold one \"left\" and one \"right\" entry");
    }
    seen[index] = true;
    if (!fields.InvertibleMatrix(viewFields.Find("view"), eyeName + " view", &pose->eyes[index].view) ||
      !fields.InvertibleMatrix(
        viewFields.Find("projection"), eyeName + " projection", &pose->eyes[index].projection))
    {
      return false;
    }
  }
  return true;
}

bool ParseInteraction(const FieldReader& fields, InteractionMessage* interaction)
{
  std::string action;
  if (!fields.String("action", &action))
  {
    return false;
  }
  if (action == "grab-start")
  {
    interaction->action = InteractionAction::GrabStart;
  }
  else if (action == "grab-end")
  {
    interaction->action = InteractionAction::GrabEnd;
  }
  else if (action == "reset-placement")
  {
    interaction->action = InteractionAction::ResetPlacement;
  }
  else if (action == "grab-move")
  {
    interaction->action = InteractionAction::GrabMove;
    return fields.InvertibleMatrix(fields.Find("transform"), "transform", &interaction->transform);
  }
  else if (action == "cutting-plane")
  {
    interaction->action = InteractionAction::CuttingPlane;
    if (!fields.Boolean("enabled", &interaction->enabled))
    {
      return false;
    }
    if (!interaction->enabled)
    {
      return true;
    }
    if (!fields.Numbers("origin", &interaction->origin) ||
      !fields.Numbers("normal", &interaction->normal))
    {
      return false;
    }
    const double length = std::sqrt(interaction->normal[0] * interaction->normal[0] +
      interaction->normal[1] * interaction->normal[1] +
      interaction->normal[2] * interaction->normal[2]);
    if (!(length > 1e-9))
    {
      return fields.Fail("'normal' must not be zero");
    }
    for (double& component : interaction->normal)
    {
      component /= length;
    }
  }
  else if (action == "illumination")
  {
    interaction->action = InteractionAction::Illumination;
    return fields.String("model", &interaction->name);
  }
  else if (action == "transfer-function")
  {
    interaction->action = InteractionAction::TransferFunction;
    return fields.String("preset", &interaction->name);
  }
  else
  {
    return fields.Fail("unknown action '" + action.substr(0, 32) + "'");
  }
  return true;
}

json MatrixJson(const Matrix4& matrix)
{
  return json(std::vector<double>(matrix.begin(), matrix.end()));
}

json EyesJson(const EyeMatrices eyes[2])
{
  json views = json::array();
  for (int eye = 0; eye < 2; ++eye)
  {
    views.push_back({ { "eye", eye == 0 ? "left" : "right" },
      { "view", MatrixJson(eyes[eye].view) }, { "projection", MatrixJson(eyes[eye].projection) } });
  }
  return views;
}
}

Matrix4 IdentityMatrix()
{
  Matrix4 m{};
  m[0] = m[5] = m[10] = m[15] = 1.0;
  return m;
}

// The protocol's matrices have GLM's layout (column-major), so GLM does the algebra.
namespace
{
glm::dmat4 ToGlm(const Matrix4& m)
{
  return glm::make_mat4(m.data());
}

Matrix4 FromGlm(const glm::dmat4& m)
{
  Matrix4 result;
  std::copy_n(glm::value_ptr(m), 16, result.begin());
  return result;
}
}

Matrix4 Multiply(const Matrix4& a, const Matrix4& b)
{
  return FromGlm(ToGlm(a) * ToGlm(b));
}

bool Invert(const Matrix4& m, Matrix4* inverse)
{
  double scale = 0.0;
  for (double value : m)
  {
    scale = std::max(scale, std::fabs(value));
  }
  if (!(scale > 0.0) || !std::isfinite(scale))
  {
    return false;
  }
  // Singular relative to the matrix's own magnitude (a projection's entries can be tiny).
  const double determinant = glm::determinant(ToGlm(m));
  if (!(std::fabs(determinant) > 1e-12 * scale * scale * scale * scale))
  {
    return false;
  }
  *inverse = FromGlm(glm::inverse(ToGlm(m)));
  return true;
}

Matrix4 PerspectiveProjection(double fovYDegrees, double aspect, double nearPlane, double farPlane)
{
  return FromGlm(glm::perspective(glm::radians(fovYDegrees), aspect, nearPlane, farPlane));
}

const char* CodecName(Codec codec)
{
  return codec == Codec::H264 ? "h264" : "jpeg";
}

bool ParseClientMessage(std::string_view text, ClientMessage* message, std::string* reason)
{
  if (!WithinDepth(text))
  {
    *reason = "message nested deeper than " + std::to_string(MaximumJsonDepth) + " levels";
    return false;
  }
  const json document = json::parse(text.begin(), text.end(), nullptr, false);
  if (document.is_discarded())
  {
    *reason = "not valid JSON";
    return false;
  }
  if (!document.is_object())
  {
    *reason = "a message must be a JSON object";
    return false;
  }
  const auto type = document.find("type");
  if (type == document.end() || !type->is_string())
  {
    *reason = "a message needs a string 'type'";
    return false;
  }
  const std::string& name = type->get_ref<const std::string&>();
  if (name == "hello")
  {
    message->type = ClientMessageType::Hello;
    return ParseHello(FieldReader(document, "hello", reason), &message->hello);
  }
  if (name == "pose")
  {
    message->type = ClientMessageType::Pose;
    return ParsePose(FieldReader(document, "pose", reason), &message->pose);
  }
  if (name == "interaction")
  {
    message->type = ClientMessageType::Interaction;
    return ParseInteraction(FieldReader(document, "interaction", reason), &message->interaction);
  }
  if (name == "displayed")
  {
    message->type = ClientMessageType::Displayed;
    const FieldReader fields(document, "displayed", reason);
    return fields.Counter("frameId", &message->displayed.frameId) &&
      fields.Counter("poseId", &message->displayed.poseId) &&
      fields.Number("poseToDisplayMs", &message->displayed.poseToDisplayMs);
  }
  if (name == "decoded")
  {
    message->type = ClientMessageType::Decoded;
    return FieldReader(document, "decoded", reason).Counter("frameId", &message->decoded.frameId);
  }
  if (name == "ping")
  {
    message->type = ClientMessageType::Ping;
    return FieldReader(document, "ping", reason).Number("clientTime", &message->ping.clientTime);
  }
  *reason = "unknown message type '" + name.substr(0, 32) + "'";
  return false;
}

std::string SerializeHello(const HelloMessage& hello)
{
  json codecs = json::array({ "jpeg" });
  if (hello.decodesH264)
  {
    codecs.push_back("h264");
  }
  return json({ { "type", "hello" }, { "protocol", hello.protocol },
                { "role", hello.role == Role::Controller ? "controller" : "spectator" },
                { "client", hello.client }, { "codecs", codecs } })
    .dump();
}

std::string SerializePose(const PoseMessage& pose)
{
  return json({ { "type", "pose" }, { "poseId", pose.poseId }, { "mode", pose.mode },
                { "head", MatrixJson(pose.head) }, { "views", EyesJson(pose.eyes) } })
    .dump();
}

std::string SerializeInteraction(const InteractionMessage& interaction)
{
  json message = { { "type", "interaction" } };
  switch (interaction.action)
  {
    case InteractionAction::GrabStart:
      message["action"] = "grab-start";
      break;
    case InteractionAction::GrabMove:
      message["action"] = "grab-move";
      message["transform"] = MatrixJson(interaction.transform);
      break;
    case InteractionAction::GrabEnd:
      message["action"] = "grab-end";
      break;
    case InteractionAction::ResetPlacement:
      message["action"] = "reset-placement";
      break;
    case InteractionAction::CuttingPlane:
      message["action"] = "cutting-plane";
      message["enabled"] = interaction.enabled;
      message["origin"] = interaction.origin;
      message["normal"] = interaction.normal;
      break;
    case InteractionAction::Illumination:
      message["action"] = "illumination";
      message["model"] = interaction.name;
      break;
    case InteractionAction::TransferFunction:
      message["action"] = "transfer-function";
      message["preset"] = interaction.name;
      break;
  }
  return message.dump();
}

std::string SerializeDisplayed(const DisplayedMessage& displayed)
{
  return json({ { "type", "displayed" }, { "frameId", displayed.frameId },
                { "poseId", displayed.poseId }, { "poseToDisplayMs", displayed.poseToDisplayMs } })
    .dump();
}

std::string SerializeDecoded(const DecodedMessage& decoded)
{
  return json({ { "type", "decoded" }, { "frameId", decoded.frameId } }).dump();
}

std::string SerializeWelcome(const WelcomeInfo& info, Role role, Codec codec)
{
  return json({ { "type", "welcome" }, { "protocol", ProtocolVersion },
                { "role", role == Role::Controller ? "controller" : "spectator" },
                { "server", info.server }, { "codec", CodecName(codec) },
                { "eyeWidth", info.eyeWidth }, { "eyeHeight", info.eyeHeight },
                { "illuminationModels", info.illuminationModels },
                { "illuminationModel", info.illuminationModel }, { "presets", info.presets },
                { "preset", info.preset }, { "volumeCenter", info.volumeCenter },
                { "volumeRadius", info.volumeRadius } })
    .dump();
}

std::string SerializeError(std::string_view reason)
{
  // The reason may quote client input: dump() escapes it, and invalid UTF-8 is replaced.
  return json({ { "type", "error" }, { "reason", std::string(reason) } })
    .dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string SerializePong(double clientTime)
{
  return json({ { "type", "pong" }, { "clientTime", clientTime } }).dump();
}

std::string SerializeStats(const ServerStatistics& s)
{
  return json({ { "type", "stats" }, { "frameId", s.frameId }, { "fps", s.framesPerSecond },
                { "renderMs", s.renderMs }, { "denoiseMs", s.denoiseMs },
                { "encodeMs", s.encodeMs }, { "sendMs", s.sendMs },
                { "poseToDisplayMs", s.poseToDisplayMs }, { "clients", s.clients },
                { "droppedFrames", s.droppedFrames } })
    .dump();
}

bool ParseServerTextMessage(std::string_view text, ServerTextMessage* message, std::string* reason)
{
  const json document = json::parse(text.begin(), text.end(), nullptr, false);
  if (document.is_discarded() || !document.is_object() || !document.contains("type") ||
    !document["type"].is_string())
  {
    *reason = "not a server message";
    return false;
  }
  message->type = document["type"].get<std::string>();
  const auto number = [&](const char* name, double fallback = 0.0) {
    const auto it = document.find(name);
    return it != document.end() && it->is_number() ? it->get<double>() : fallback;
  };
  // Counts and sizes arrive as JSON numbers; one beyond its C++ type is refused (see
  // FitsCount). The first such field names the reason.
  std::string outOfRange;
  const auto count = [&](const char* name, const CountRange& range) {
    const double value = number(name);
    if (FitsCount(value, range))
    {
      return value;
    }
    if (outOfRange.empty())
    {
      outOfRange = message->type + ": '" + name + "' must be from 0 to " + range.maximum;
    }
    return 0.0;
  };
  const auto string = [&](const char* name) {
    const auto it = document.find(name);
    return it != document.end() && it->is_string() ? it->get<std::string>() : std::string();
  };
  const auto strings = [&](const char* name) {
    std::vector<std::string> values;
    const auto it = document.find(name);
    if (it != document.end() && it->is_array())
    {
      for (const json& value : *it)
      {
        if (value.is_string())
        {
          values.push_back(value.get<std::string>());
        }
      }
    }
    return values;
  };
  if (message->type == "welcome")
  {
    message->role = string("role") == "spectator" ? Role::Spectator : Role::Controller;
    message->codec = string("codec") == "h264" ? Codec::H264 : Codec::Jpeg;
    WelcomeInfo& info = message->welcome;
    info.server = string("server");
    info.eyeWidth = static_cast<int>(count("eyeWidth", IntRange));
    info.eyeHeight = static_cast<int>(count("eyeHeight", IntRange));
    if (!outOfRange.empty())
    {
      *reason = outOfRange;
      return false;
    }
    info.illuminationModels = strings("illuminationModels");
    info.illuminationModel = string("illuminationModel");
    info.presets = strings("presets");
    info.preset = string("preset");
    info.volumeRadius = number("volumeRadius");
    FieldReader fields(document, "welcome", reason);
    return fields.Numbers("volumeCenter", &info.volumeCenter);
  }
  if (message->type == "stats")
  {
    ServerStatistics& s = message->stats;
    s.frameId = static_cast<std::uint64_t>(count("frameId", CounterRange));
    s.framesPerSecond = number("fps");
    s.renderMs = number("renderMs");
    s.denoiseMs = number("denoiseMs");
    s.encodeMs = number("encodeMs");
    s.sendMs = number("sendMs");
    s.poseToDisplayMs = number("poseToDisplayMs");
    s.clients = static_cast<int>(count("clients", IntRange));
    s.droppedFrames = static_cast<std::uint64_t>(count("droppedFrames", CounterRange));
    if (!outOfRange.empty())
    {
      *reason = outOfRange;
      return false;
    }
  }
  else if (message->type == "error")
  {
    message->reason = string("reason");
  }
  else if (message->type == "pong")
  {
    message->clientTime = number("clientTime");
  }
  return true;
}

std::string EncodeFrameMessage(
  const FrameHeader& header, std::string_view leftEye, std::string_view rightEye)
{
  json eyes = EyesJson(header.eyes);
  eyes[0]["offset"] = 0;
  eyes[0]["length"] = leftEye.size();
  eyes[1]["offset"] = leftEye.size();
  eyes[1]["length"] = rightEye.size();
  json document = { { "frameId", header.frameId }, { "poseId", header.poseId },
    { "codec", CodecName(header.codec) }, { "keyFrame", header.keyFrame },
    { "width", header.width }, { "height", header.height },
    { "serverTimeMs", header.serverTimeMs },
    { "timings",
      { { "renderMs", header.renderMs }, { "denoiseMs", header.denoiseMs },
        { "encodeMs", header.encodeMs } } },
    { "volumeCenter", header.volumeCenter }, { "eyes", eyes } };
  if (!header.illuminationModel.empty() || !header.preset.empty())
  {
    document["scene"] = { { "illuminationModel", header.illuminationModel },
      { "preset", header.preset }, { "cuttingPlane", header.cuttingPlane } };
  }
  if (header.codec == Codec::H264)
  {
    document["codecString"] = header.codecString;
  }
  const std::string headerText = document.dump();
  std::string message;
  message.reserve(8 + headerText.size() + leftEye.size() + rightEye.size());
  message.append("HVF1");
  const auto length = static_cast<std::uint32_t>(headerText.size());
  for (int byte = 0; byte < 4; ++byte)
  {
    message.push_back(static_cast<char>((length >> (8 * byte)) & 0xffu));
  }
  message.append(headerText);
  message.append(leftEye);
  message.append(rightEye);
  return message;
}

bool DecodeFrameMessage(
  std::string_view message, FrameHeader* header, EyeImage eyes[2], std::string* reason)
{
  if (message.size() < 8 || message.substr(0, 4) != "HVF1")
  {
    *reason = "frame: no HVF1 container";
    return false;
  }
  std::uint32_t length = 0;
  for (int byte = 0; byte < 4; ++byte)
  {
    length |= static_cast<std::uint32_t>(static_cast<unsigned char>(message[4 + byte])) << (8 * byte);
  }
  if (length > message.size() - 8)
  {
    *reason = "frame: header length beyond the message";
    return false;
  }
  const std::string_view headerText = message.substr(8, length);
  const std::string_view payload = message.substr(8 + length);
  const json document = json::parse(headerText.begin(), headerText.end(), nullptr, false);
  if (document.is_discarded() || !document.is_object())
  {
    *reason = "frame: header is not a JSON object";
    return false;
  }
  const FieldReader fields(document, "frame", reason);
  double width = 0, height = 0, serverTime = 0;
  std::string codec;
  if (!fields.Counter("frameId", &header->frameId) || !fields.Counter("poseId", &header->poseId) ||
    !fields.String("codec", &codec) || !fields.Boolean("keyFrame", &header->keyFrame) ||
    !fields.Number("width", &width) || !fields.Number("height", &height) ||
    !fields.Number("serverTimeMs", &serverTime) ||
    !fields.Numbers("volumeCenter", &header->volumeCenter))
  {
    return false;
  }
  if (!FitsCount(width, IntRange) || !FitsCount(height, IntRange))
  {
    return fields.Fail(std::string("'width' and 'height' must be from 0 to ") + IntRange.maximum);
  }
  header->codec = codec == "h264" ? Codec::H264 : Codec::Jpeg;
  header->width = static_cast<int>(width);
  header->height = static_cast<int>(height);
  header->serverTimeMs = serverTime;
  if (header->codec == Codec::H264 && !fields.String("codecString", &header->codecString))
  {
    return false;
  }
  if (const json* scene = fields.Find("scene"); scene && scene->is_object())
  {
    const FieldReader sceneFields(*scene, "frame scene", reason);
    if (!sceneFields.String("illuminationModel", &header->illuminationModel) ||
      !sceneFields.String("preset", &header->preset) ||
      !sceneFields.Boolean("cuttingPlane", &header->cuttingPlane))
    {
      return false;
    }
  }
  if (const json* timings = fields.Find("timings"); timings && timings->is_object())
  {
    const FieldReader timing(*timings, "frame timings", reason);
    if (!timing.Number("renderMs", &header->renderMs) ||
      !timing.Number("denoiseMs", &header->denoiseMs) ||
      !timing.Number("encodeMs", &header->encodeMs))
    {
      return false;
    }
  }
  const json* eyeList = fields.Find("eyes");
  if (!eyeList || !eyeList->is_array() || eyeList->size() != 2)
  {
    return fields.Fail("'eyes' must hold two entries");
  }
  for (int eye = 0; eye < 2; ++eye)
  {
    const json& entry = (*eyeList)[eye];
    if (!entry.is_object())
    {
      return fields.Fail("each eye must be an object");
    }
    const FieldReader eyeFields(entry, "frame eye", reason);
    std::uint64_t offset = 0, size = 0;
    if (!eyeFields.InvertibleMatrix(eyeFields.Find("view"), "view", &header->eyes[eye].view) ||
      !eyeFields.InvertibleMatrix(
        eyeFields.Find("projection"), "projection", &header->eyes[eye].projection) ||
      !eyeFields.Counter("offset", &offset) || !eyeFields.Counter("length", &size))
    {
      return false;
    }
    if (offset > payload.size() || size > payload.size() - offset)
    {
      return fields.Fail("an eye's image lies outside the message");
    }
    eyes[eye].matrices = header->eyes[eye];
    eyes[eye].data = payload.substr(offset, size);
  }
  return true;
}
}
}
