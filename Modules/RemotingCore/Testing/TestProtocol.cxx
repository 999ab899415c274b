// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// The protocol's parser accepts what the protocol page describes and rejects everything
// else with a reason that names the problem; frames survive a round trip through the HVF1
// container and damaged containers are refused.
#include "hv/remoting/Protocol.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace hv::remoting;

namespace
{
std::string Matrix(const Matrix4& m)
{
  std::string text = "[";
  for (int i = 0; i < 16; ++i)
  {
    text += (i ? "," : "") + std::to_string(m[i]);
  }
  return text + "]";
}

Matrix4 Translation(double x, double y, double z)
{
  Matrix4 m = IdentityMatrix();
  m[12] = x;
  m[13] = y;
  m[14] = z;
  return m;
}


std::string PoseText(const std::string& views)
{
  return R"({"type":"pose","poseId":7,"mode":"immersive-ar","head":)" +
    Matrix(Translation(0, 1.6, 0)) + R"(,"views":)" + views + "}";
}

std::string View(const char* eye, const Matrix4& view, const Matrix4& projection)
{
  return std::string(R"({"eye":")") + eye + R"(","view":)" + Matrix(view) +
    R"(,"projection":)" + Matrix(projection) + "}";
}
}

TEST(Protocol, ParsesAPoseWithAsymmetricFrustums)
{
  Matrix4 left = PerspectiveProjection(60, 1.5, 0.1, 10);
  left[8] = 0.12; // an off-axis frustum, as a HoloLens 2 reports
  const Matrix4 right = PerspectiveProjection(60, 1.5, 0.1, 10);
  const std::string text = PoseText("[" + View("right", Translation(-0.032, -1.6, 0), right) + "," +
    View("left", Translation(0.032, -1.6, 0), left) + "]");
  ClientMessage message;
  std::string reason;
  ASSERT_TRUE(ParseClientMessage(text, &message, &reason)) << reason;
  EXPECT_EQ(message.type, ClientMessageType::Pose);
  EXPECT_EQ(message.pose.poseId, 7u);
  EXPECT_EQ(message.pose.mode, "immersive-ar");
  // Entries are matched by name, not by position.
  EXPECT_DOUBLE_EQ(message.pose.eyes[0].projection[8], 0.12);
  EXPECT_DOUBLE_EQ(message.pose.eyes[0].view[12], 0.032);
  EXPECT_DOUBLE_EQ(message.pose.eyes[1].view[12], -0.032);
}

TEST(Protocol, SerializedClientMessagesParseBack)
{
  PoseMessage pose;
  pose.poseId = 123456789012ull;
  pose.mode = "desktop";
  pose.head = Translation(1, 2, 3);
  pose.eyes[0] = { Translation(-1, -2, -3), PerspectiveProjection(50, 1, 0.05, 20) };
  pose.eyes[1] = { Translation(-1.06, -2, -3), PerspectiveProjection(50, 1, 0.05, 20) };
  ClientMessage message;
  std::string reason;
  ASSERT_TRUE(ParseClientMessage(SerializePose(pose), &message, &reason)) << reason;
  EXPECT_EQ(message.pose.poseId, pose.poseId);
  for (int i = 0; i < 16; ++i)
  {
    EXPECT_DOUBLE_EQ(message.pose.eyes[1].view[i], pose.eyes[1].view[i]);
    EXPECT_DOUBLE_EQ(message.pose.eyes[0].projection[i], pose.eyes[0].projection[i]);
  }

  InteractionMessage plane;
  plane.action = InteractionAction::CuttingPlane;
  plane.enabled = true;
  plane.origin = { 0.0, 1.4, -0.8 };
  plane.normal = { 0.0, 0.0, 2.0 };
  ASSERT_TRUE(ParseClientMessage(SerializeInteraction(plane), &message, &reason)) << reason;
  EXPECT_EQ(message.interaction.action, InteractionAction::CuttingPlane);
  EXPECT_DOUBLE_EQ(message.interaction.normal[2], 1.0); // normalised
  EXPECT_DOUBLE_EQ(message.interaction.origin[1], 1.4);

  InteractionMessage grab;
  grab.action = InteractionAction::GrabMove;
  grab.transform = Translation(0.1, 0, 0);
  ASSERT_TRUE(ParseClientMessage(SerializeInteraction(grab), &message, &reason)) << reason;
  EXPECT_EQ(message.interaction.action, InteractionAction::GrabMove);
  EXPECT_DOUBLE_EQ(message.interaction.transform[12], 0.1);

  HelloMessage hello;
  hello.protocol = 1;
  hello.role = Role::Spectator;
  hello.decodesH264 = true;
  ASSERT_TRUE(ParseClientMessage(SerializeHello(hello), &message, &reason)) << reason;
  EXPECT_EQ(message.hello.role, Role::Spectator);
  EXPECT_TRUE(message.hello.decodesH264);

  ASSERT_TRUE(ParseClientMessage(SerializeDisplayed({ 5, 4, 81.5 }), &message, &reason)) << reason;
  EXPECT_DOUBLE_EQ(message.displayed.poseToDisplayMs, 81.5);

  ASSERT_TRUE(ParseClientMessage(SerializeDecoded({ 12 }), &message, &reason)) << reason;
  EXPECT_EQ(message.type, ClientMessageType::Decoded);
  EXPECT_EQ(message.decoded.frameId, 12u);
}

TEST(Protocol, RejectsWhatTheProtocolDoesNotAllowWithAReason)
{
  const Matrix4 projection = PerspectiveProjection(60, 1, 0.1, 10);
  const std::string goodViews = "[" + View("left", IdentityMatrix(), projection) + "," +
    View("right", IdentityMatrix(), projection) + "]";
  Matrix4 singular = IdentityMatrix();
  singular[5] = 0.0;
  const struct
  {
    std::string text;
    std::string reason;
  } cases[] = {
    { "", "not valid JSON" },
    { "{\"type\":\"pose\"", "not valid JSON" },
    { "[1,2,3]", "must be a JSON object" },
    { "{\"poseId\":1}", "needs a string 'type'" },
    { "{\"type\":\"teleport\"}", "unknown message type 'teleport'" },
    { "{\"type\":\"hello\"}", "'protocol' must be a number" },
    { "{\"type\":\"hello\",\"protocol\":1,\"role\":\"admin\"}", "'role' must be" },
    { "{\"type\":\"pose\"}", "'poseId' must be an integer >= 0" },
    { "{\"type\":\"pose\",\"poseId\":-3}", "'poseId' must be an integer >= 0" },
    { "{\"type\":\"pose\",\"poseId\":1.5}", "'poseId' must be an integer >= 0" },
    { PoseText("[]"), "'views' must hold two entries" },
    { PoseText("[" + View("left", IdentityMatrix(), projection) + "," +
        View("left", IdentityMatrix(), projection) + "]"),
      "one \"left\" and one \"right\"" },
    { PoseText("[" + View("left", singular, projection) + "," +
        View("right", IdentityMatrix(), projection) + "]"),
      "'left view' is not invertible" },
    { PoseText("[" + View("left", IdentityMatrix(), projection) + ",{\"eye\":\"right\",\"view\":[1,2]}]"),
      "'right view' must hold 16 numbers" },
    // A number that overflows a double is refused by the JSON parser already.
    { R"({"type":"pose","poseId":1,"head":[1e999,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1],"views":)" + goodViews + "}",
      "not valid JSON" },
    { R"({"type":"pose","poseId":1,"head":[0,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1],"views":)" + goodViews + "}",
      "'head' is not invertible" },
    { R"({"type":"interaction","action":"explode"})", "unknown action 'explode'" },
    { R"({"type":"interaction","action":"cutting-plane","enabled":true,"origin":[0,0,0],"normal":[0,0,0]})",
      "'normal' must not be zero" },
    { R"({"type":"interaction","action":"cutting-plane","enabled":"yes"})", "'enabled' must be true or false" },
    { R"({"type":"interaction","action":"illumination","model":7})", "'model' must be a string" },
    { R"({"type":"interaction","action":"transfer-function","preset":")" + std::string(100, 'x') + "\"}",
      "'preset' is longer than 64 characters" },
    { R"({"type":"displayed","frameId":1,"poseId":1})", "'poseToDisplayMs' must be a number" },
    { R"({"type":"decoded","frameId":-3})", "'frameId' must be an integer >= 0" },
    { std::string(20, '[') + std::string(20, ']'), "nested deeper than 8 levels" },
  };
  for (const auto& testCase : cases)
  {
    ClientMessage message;
    std::string reason;
    EXPECT_FALSE(ParseClientMessage(testCase.text, &message, &reason)) << testCase.text;
    EXPECT_NE(reason.find(testCase.reason), std::string::npos)
      << "message: " << testCase.text.substr(0, 80) << "\nreason: " << reason
      << "\nexpected: " << testCase.reason;
  }
  // Nesting in strings does not count.
  ClientMessage message;
  std::string reason;
  EXPECT_TRUE(ParseClientMessage(
    R"({"type":"hello","protocol":1,"client":"[[[[[[[[[[[[[[[[[[[[","codecs":["jpeg"]})", &message, &reason))
    << reason;
}

TEST(Protocol, MatrixInverseAndProduct)
{
  Matrix4 m = PerspectiveProjection(70, 1.3, 0.2, 30);
  m[8] = -0.2;
  m[9] = 0.1;
  Matrix4 inverse;
  ASSERT_TRUE(Invert(m, &inverse));
  const Matrix4 product = Multiply(m, inverse);
  for (int i = 0; i < 16; ++i)
  {
    EXPECT_NEAR(product[i], (i % 5 == 0) ? 1.0 : 0.0, 1e-12);
  }
  // Column-major: translating then reading element 12..14.
  const Matrix4 moved = Multiply(Translation(1, 2, 3), Translation(4, 5, 6));
  EXPECT_DOUBLE_EQ(moved[12], 5.0);
  EXPECT_DOUBLE_EQ(moved[14], 9.0);
  Matrix4 zero{};
  EXPECT_FALSE(Invert(zero, &inverse));
}

TEST(Protocol, FrameContainerRoundTripAndDamage)
{
  FrameHeader header;
  header.frameId = 9;
  header.poseId = 41;
  header.codec = Codec::H264;
  header.codecString = "avc1.42c028";
  header.keyFrame = false;
  header.width = 64;
  header.height = 32;
  header.renderMs = 12.5;
  header.volumeCenter = { 0.0, 1.4, -0.8 };
  header.eyes[0] = { Translation(0.03, 0, 0), PerspectiveProjection(60, 2, 0.1, 10) };
  header.eyes[1] = { Translation(-0.03, 0, 0), PerspectiveProjection(60, 2, 0.1, 10) };
  header.illuminationModel = "gradient-phong";
  header.preset = "translucent";
  header.cuttingPlane = true;
  const std::string left = "left-eye-bytes", right = std::string("right\0eye", 9);
  const std::string message = EncodeFrameMessage(header, left, right);
  ASSERT_EQ(message.substr(0, 4), "HVF1");

  FrameHeader decoded;
  EyeImage eyes[2];
  std::string reason;
  ASSERT_TRUE(DecodeFrameMessage(message, &decoded, eyes, &reason)) << reason;
  EXPECT_EQ(decoded.frameId, 9u);
  EXPECT_EQ(decoded.poseId, 41u);
  EXPECT_EQ(decoded.codec, Codec::H264);
  EXPECT_EQ(decoded.codecString, "avc1.42c028");
  EXPECT_FALSE(decoded.keyFrame);
  EXPECT_DOUBLE_EQ(decoded.renderMs, 12.5);
  EXPECT_EQ(eyes[0].data, left);
  EXPECT_EQ(eyes[1].data, right);
  EXPECT_DOUBLE_EQ(eyes[1].matrices.view[12], -0.03);
  EXPECT_EQ(decoded.illuminationModel, "gradient-phong");
  EXPECT_EQ(decoded.preset, "translucent");
  EXPECT_TRUE(decoded.cuttingPlane);

  // Truncated payload, a header length beyond the message, a wrong magic.
  EXPECT_FALSE(DecodeFrameMessage(message.substr(0, message.size() - 3), &decoded, eyes, &reason));
  EXPECT_NE(reason.find("outside the message"), std::string::npos) << reason;
  std::string longHeader = message;
  longHeader[7] = '\x7f';
  EXPECT_FALSE(DecodeFrameMessage(longHeader, &decoded, eyes, &reason));
  EXPECT_NE(reason.find("header length"), std::string::npos) << reason;
  EXPECT_FALSE(DecodeFrameMessage("HVF2" + message.substr(4), &decoded, eyes, &reason));

  // An image width beyond int is refused, not converted (undefined behaviour).
  const std::size_t headerLength = static_cast<unsigned char>(message[4]) |
    static_cast<unsigned char>(message[5]) << 8 | static_cast<unsigned char>(message[6]) << 16;
  std::string headerText = message.substr(8, headerLength);
  const std::size_t width = headerText.find("\"width\":64");
  ASSERT_NE(width, std::string::npos) << headerText;
  headerText.replace(width, 10, "\"width\":1e30");
  std::string hugeWidth = "HVF1";
  for (int byte = 0; byte < 4; ++byte)
  {
    hugeWidth.push_back(static_cast<char>((headerText.size() >> (8 * byte)) & 0xffu));
  }
  hugeWidth += headerText + message.substr(8 + headerLength);
  EXPECT_FALSE(DecodeFrameMessage(hugeWidth, &decoded, eyes, &reason));
  EXPECT_NE(reason.find("'width'"), std::string::npos) << reason;
}

TEST(Protocol, ServerMessagesParseBackInTheClient)
{
  WelcomeInfo info;
  info.eyeWidth = 1440;
  info.eyeHeight = 936;
  info.illuminationModels = { "path-traced", "emission-absorption" };
  info.illuminationModel = "path-traced";
  info.presets = { "head-mri", "bone" };
  info.volumeCenter = { 0, 1.4, -0.8 };
  info.volumeRadius = 0.15;
  ServerTextMessage message;
  std::string reason;
  ASSERT_TRUE(ParseServerTextMessage(SerializeWelcome(info, Role::Spectator, Codec::H264), &message, &reason));
  EXPECT_EQ(message.type, "welcome");
  EXPECT_EQ(message.role, Role::Spectator);
  EXPECT_EQ(message.codec, Codec::H264);
  EXPECT_EQ(message.welcome.eyeWidth, 1440);
  EXPECT_EQ(message.welcome.presets.size(), 2u);
  EXPECT_DOUBLE_EQ(message.welcome.volumeCenter[2], -0.8);
  // Client text quoted in an error reason stays valid JSON even when it is not UTF-8.
  ASSERT_TRUE(ParseServerTextMessage(SerializeError("unknown message type '\xff\xfe'"), &message, &reason));
  EXPECT_EQ(message.type, "error");
}

// Integer fields beyond their C++ type are refused with a reason, not converted (that
// conversion is undefined behaviour; the fuzzer found a welcome with eyeHeight = 3.2e83).
TEST(Protocol, ServerMessagesWithOutOfRangeCountsAreRefused)
{
  ServerTextMessage message;
  std::string reason;
  EXPECT_FALSE(ParseServerTextMessage(
    R"({"type":"welcome","role":"spectator","codec":"jpeg","eyeWidth":64,"eyeHeight":3.2e83})",
    &message, &reason));
  EXPECT_NE(reason.find("eyeHeight"), std::string::npos) << reason;
  EXPECT_FALSE(ParseServerTextMessage(R"({"type":"welcome","eyeWidth":-1,"eyeHeight":4})",
    &message, &reason));
  EXPECT_NE(reason.find("eyeWidth"), std::string::npos) << reason;
  EXPECT_FALSE(ParseServerTextMessage(R"({"type":"stats","frameId":1e30,"clients":1})",
    &message, &reason));
  EXPECT_NE(reason.find("frameId"), std::string::npos) << reason;
  EXPECT_FALSE(ParseServerTextMessage(R"({"type":"stats","frameId":3,"clients":4294967296})",
    &message, &reason));
  EXPECT_NE(reason.find("clients"), std::string::npos) << reason;
  // The largest values that fit are kept.
  ASSERT_TRUE(ParseServerTextMessage(
    R"({"type":"stats","frameId":18446744073709549568,"clients":2147483647,"droppedFrames":0})",
    &message, &reason))
    << reason;
  EXPECT_EQ(message.stats.clients, 2147483647);
  EXPECT_EQ(message.stats.frameId, 18446744073709549568ull);
}
