// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Messages of the HoloVolume remoting protocol, version 1 (Documentation/RemotingProtocol.md):
// strict parsing of what clients send, serialisation of what the server sends, and the binary
// "HVF1" frame container. VTK-free; the parser is the libFuzzer target.
#ifndef hv_remoting_Protocol_h
#define hv_remoting_Protocol_h

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace hv
{
namespace remoting
{
constexpr int ProtocolVersion = 1;
// A client message larger than this closes the connection (WebSocket close code 1009).
constexpr std::size_t DefaultMaximumClientMessageBytes = 65536;
// JSON nesting deeper than this is rejected before parsing (no message needs more than 3).
constexpr int MaximumJsonDepth = 8;

// 16 numbers, column-major, as WebXR and WebGL give them (element 12..14 = translation).
using Matrix4 = std::array<double, 16>;
Matrix4 IdentityMatrix();
Matrix4 Multiply(const Matrix4& a, const Matrix4& b);
// General inverse; returns false for a singular matrix.
bool Invert(const Matrix4& m, Matrix4* inverse);
// A symmetric OpenGL perspective projection (what a desktop client or a default view uses).
Matrix4 PerspectiveProjection(double fovYDegrees, double aspect, double nearPlane, double farPlane);

enum class Role
{
  Controller,
  Spectator
};
enum class Codec
{
  Jpeg,
  H264
};
const char* CodecName(Codec codec);

struct EyeMatrices
{
  Matrix4 view;       // world to eye
  Matrix4 projection; // eye to clip
};

struct HelloMessage
{
  int protocol = 0;
  Role role = Role::Controller;
  std::string client;
  bool decodesH264 = false;
};

struct PoseMessage
{
  std::uint64_t poseId = 0;
  std::string mode;
  Matrix4 head{};
  EyeMatrices eyes[2]{}; // 0 left, 1 right
};

enum class InteractionAction
{
  GrabStart,
  GrabMove,
  GrabEnd,
  ResetPlacement,
  CuttingPlane,
  Illumination,
  TransferFunction
};

struct InteractionMessage
{
  InteractionAction action = InteractionAction::GrabEnd;
  Matrix4 transform{};             // GrabMove: world transform from grab start to now
  bool enabled = false;            // CuttingPlane
  std::array<double, 3> origin{};  // CuttingPlane, world
  std::array<double, 3> normal{};  // CuttingPlane, unit, the kept side
  std::string name;                // Illumination model or transfer-function preset
};

struct DisplayedMessage
{
  std::uint64_t frameId = 0;
  std::uint64_t poseId = 0;
  double poseToDisplayMs = 0.0;
};

// Flow control: the client has finished with every frame up to frameId (decoded, or dropped
// or skipped without decoding). Cumulative, so a lost or merged acknowledgement costs nothing.
struct DecodedMessage
{
  std::uint64_t frameId = 0;
};

struct PingMessage
{
  double clientTime = 0.0;
};

enum class ClientMessageType
{
  Hello,
  Pose,
  Interaction,
  Displayed,
  Decoded,
  Ping
};

struct ClientMessage
{
  ClientMessageType type = ClientMessageType::Ping;
  HelloMessage hello;
  PoseMessage pose;
  InteractionMessage interaction;
  DisplayedMessage displayed;
  DecodedMessage decoded;
  PingMessage ping;
};

// Parses one text message from a client. Returns false and a reason that names the field
// ("pose: 'views' must hold two entries") for anything the protocol does not allow:
// malformed JSON, nesting deeper than MaximumJsonDepth, unknown types or actions, missing or
// ill-typed fields, non-finite numbers, singular view or projection matrices, a zero normal.
bool ParseClientMessage(std::string_view text, ClientMessage* message, std::string* reason);

// Client-side serialisation (the C++ loopback client, tests and benchmark).
std::string SerializeHello(const HelloMessage& hello);
std::string SerializePose(const PoseMessage& pose);
std::string SerializeInteraction(const InteractionMessage& interaction);
std::string SerializeDisplayed(const DisplayedMessage& displayed);
std::string SerializeDecoded(const DecodedMessage& decoded);

// What the server tells a client in its welcome message.
struct WelcomeInfo
{
  std::string server = "HoloVolume";
  int eyeWidth = 0;
  int eyeHeight = 0;
  std::vector<std::string> illuminationModels;
  std::string illuminationModel;
  std::vector<std::string> presets;
  std::string preset;
  std::array<double, 3> volumeCenter{}; // world, metres
  double volumeRadius = 0.0;            // metres
};
std::string SerializeWelcome(const WelcomeInfo& info, Role role, Codec codec);
std::string SerializeError(std::string_view reason);
std::string SerializePong(double clientTime);

struct ServerStatistics
{
  std::uint64_t frameId = 0;
  double framesPerSecond = 0.0;
  double renderMs = 0.0;
  double denoiseMs = 0.0;
  double encodeMs = 0.0;
  double sendMs = 0.0;
  double poseToDisplayMs = 0.0;
  int clients = 0;
  std::uint64_t droppedFrames = 0;
};
std::string SerializeStats(const ServerStatistics& statistics);

// The text messages a server sends, parsed by C++ clients.
struct ServerTextMessage
{
  std::string type; // "welcome", "error", "stats", "pong"
  Role role = Role::Controller;
  Codec codec = Codec::Jpeg;
  WelcomeInfo welcome;
  ServerStatistics stats;
  std::string reason;
  double clientTime = 0.0;
};
bool ParseServerTextMessage(std::string_view text, ServerTextMessage* message, std::string* reason);

struct EyeImage
{
  EyeMatrices matrices;
  std::string_view data; // the encoded image inside the frame message
};

struct FrameHeader
{
  std::uint64_t frameId = 0;
  std::uint64_t poseId = 0;
  Codec codec = Codec::Jpeg;
  bool keyFrame = true;
  std::string codecString; // H.264 only, e.g. "avc1.42c028"
  int width = 0;
  int height = 0;
  double serverTimeMs = 0.0;
  double renderMs = 0.0;
  double denoiseMs = 0.0;
  double encodeMs = 0.0;
  std::array<double, 3> volumeCenter{};
  EyeMatrices eyes[2]{};
  // The scene this frame shows, so that a client's controls display the server's state (the
  // optional "scene" object; empty names when a frame has none).
  std::string illuminationModel;
  std::string preset;
  bool cuttingPlane = false;
};

// "HVF1", uint32 little-endian header length, JSON header, then both eyes' payloads.
std::string EncodeFrameMessage(const FrameHeader& header, std::string_view leftEye,
  std::string_view rightEye);
// Checks the container (magic, lengths, offsets inside the message) and the header fields.
bool DecodeFrameMessage(std::string_view message, FrameHeader* header, EyeImage eyes[2],
  std::string* reason);
}
}

#endif
