// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// The server on loopback with C++ clients: access token on HTTP and WebSocket, the player's
// files and nothing else, controller and spectators, rejected messages that leave the
// connection healthy, the size limit, latest-wins delivery to a client that does not read,
// H.264 key frames for joining clients, and TLS with a self-signed certificate.
#include "hv/remoting/RemotingClient.h"
#include "hv/remoting/RemotingServer.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

using namespace hv::remoting;
namespace fs = std::filesystem;

namespace
{
fs::path MakeWebRoot()
{
  const fs::path root = fs::temp_directory_path() /
    ("holovolume-remoting-test-" + std::to_string(::getpid()) + "-" +
      std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
  fs::create_directories(root / "lib");
  std::ofstream(root / "index.html") << "<!doctype html><title>player</title>";
  std::ofstream(root / "lib" / "player.js") << "export const ok = true;";
  std::ofstream(root / "notes.txt") << "not served: unknown type";
  return root;
}

Matrix4 Translation(double x, double y, double z)
{
  Matrix4 m = IdentityMatrix();
  m[12] = x;
  m[13] = y;
  m[14] = z;
  return m;
}

PoseMessage MakePose(std::uint64_t poseId, double x)
{
  PoseMessage pose;
  pose.poseId = poseId;
  pose.mode = "immersive-ar";
  pose.head = Translation(x, 1.6, 0);
  Matrix4 projection{};
  projection[0] = projection[5] = 1.0;
  projection[10] = -1.02;
  projection[11] = -1.0;
  projection[14] = -0.2;
  pose.eyes[0] = { Translation(-x + 0.032, -1.6, 0), projection };
  pose.eyes[1] = { Translation(-x - 0.032, -1.6, 0), projection };
  return pose;
}

class ServerTest : public ::testing::Test
{
protected:
  void SetUp() override { this->WebRoot = MakeWebRoot(); }
  void TearDown() override
  {
    if (this->Server)
    {
      this->Server->Stop();
    }
    fs::remove_all(this->WebRoot);
  }

  RemotingServer& StartServer(ServerOptions options = ServerOptions())
  {
    options.port = 0;
    options.webRoot = this->WebRoot.string();
    options.log = [this](const std::string& line) {
      std::lock_guard<std::mutex> lock(this->LogMutex);
      this->Log += line + "\n";
    };
    this->Server = std::make_unique<RemotingServer>(options);
    WelcomeInfo welcome;
    welcome.eyeWidth = 64;
    welcome.eyeHeight = 32;
    welcome.illuminationModels = { "path-traced" };
    welcome.presets = { "head-mri" };
    this->Server->SetWelcome(welcome);
    std::string reason;
    EXPECT_TRUE(this->Server->Start(&reason)) << reason;
    return *this->Server;
  }

  std::string Target() const { return "/ws?token=" + this->Server->GetAccessToken(); }

  // Connects and says hello; returns the welcome.
  ServerTextMessage Join(RemotingClient& client, Role role, bool h264 = false, bool tls = false)
  {
    std::string reason;
    EXPECT_TRUE(client.Connect("127.0.0.1", this->Server->GetPort(), this->Target(), tls, &reason)) << reason;
    HelloMessage hello;
    hello.protocol = 1;
    hello.role = role;
    hello.client = "loopback-test";
    hello.decodesH264 = h264;
    EXPECT_TRUE(client.SendText(SerializeHello(hello), &reason)) << reason;
    return this->NextText(client, "welcome");
  }

  // The next text message of the given type (frames and other texts are skipped).
  ServerTextMessage NextText(RemotingClient& client, const std::string& type, double timeout = 5.0)
  {
    ServerTextMessage parsed;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout);
    while (std::chrono::steady_clock::now() < deadline)
    {
      std::string message, reason;
      const auto kind = client.Receive(&message, 0.2, &reason);
      if (kind == RemotingClient::Received::Text && ParseServerTextMessage(message, &parsed, &reason) &&
        parsed.type == type)
      {
        return parsed;
      }
      if (kind == RemotingClient::Received::Closed || kind == RemotingClient::Received::Failed)
      {
        break;
      }
    }
    ADD_FAILURE() << "no '" << type << "' message";
    return parsed;
  }

  // Waits until the server holds a pose newer than the last taken.
  bool WaitForPose(PoseMessage* pose)
  {
    for (int attempt = 0; attempt < 100; ++attempt)
    {
      if (this->Server->TakeNewestPose(pose))
      {
        return true;
      }
      this->Server->WaitForActivity(0.05);
    }
    return false;
  }

  // The frameId of the next frame, skipping text messages; 0 when none comes in time.
  std::uint64_t NextFrameId(RemotingClient& client, double timeout)
  {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout);
    std::string message, reason;
    while (std::chrono::steady_clock::now() < deadline)
    {
      const auto kind = client.Receive(&message, 0.05, &reason);
      if (kind == RemotingClient::Received::Binary)
      {
        FrameHeader header;
        EyeImage eyes[2];
        EXPECT_TRUE(DecodeFrameMessage(message, &header, eyes, &reason)) << reason;
        return header.frameId;
      }
      if (kind == RemotingClient::Received::Closed || kind == RemotingClient::Received::Failed)
      {
        ADD_FAILURE() << "connection ended: " << reason;
        break;
      }
    }
    return 0;
  }
  void Acknowledge(RemotingClient& client, std::uint64_t frameId)
  {
    std::string reason;
    EXPECT_TRUE(client.SendText(SerializeDecoded({ frameId }), &reason)) << reason;
  }
  // A server with flow control (window, timeout) and a controller that has turned it on.
  RemotingServer& StartWithFlowControl(
    RemotingClient& client, int window, double timeoutSeconds, Codec codec = Codec::Jpeg)
  {
    ServerOptions options;
    options.codec = codec;
    options.maximumFramesInFlight = window;
    options.frameAcknowledgementTimeoutSeconds = timeoutSeconds;
    RemotingServer& server = this->StartServer(options);
    this->Join(client, Role::Controller, codec == Codec::H264);
    // Turns flow control on. The server answers messages in order, so the pong of a ping sent
    // after the acknowledgement proves it was handled (no frames yet for NextText to skip).
    this->Acknowledge(client, 0);
    std::string reason;
    EXPECT_TRUE(client.SendText(R"({"type":"ping","clientTime":1})", &reason)) << reason;
    this->NextText(client, "pong");
    return server;
  }

  fs::path WebRoot;
  std::unique_ptr<RemotingServer> Server;
  std::mutex LogMutex;
  std::string Log;
};

PublishedFrame MakeFrame(std::uint64_t frameId, std::uint64_t poseId, std::size_t payloadBytes,
  bool h264 = false, bool keyFrame = true)
{
  FrameHeader header;
  header.frameId = frameId;
  header.poseId = poseId;
  header.width = 64;
  header.height = 32;
  header.codec = h264 ? Codec::H264 : Codec::Jpeg;
  header.codecString = "avc1.42c01e";
  header.keyFrame = keyFrame;
  header.eyes[0] = header.eyes[1] = { IdentityMatrix(), IdentityMatrix() };
  const std::string payload(payloadBytes, static_cast<char>('a' + frameId % 26));
  PublishedFrame frame;
  frame.frameId = frameId;
  auto message = std::make_shared<const std::string>(EncodeFrameMessage(header, payload, payload));
  (h264 ? frame.h264Message : frame.jpegMessage) = message;
  frame.h264KeyFrame = keyFrame;
  return frame;
}
}

TEST_F(ServerTest, EveryHttpRequestNeedsTheToken)
{
  RemotingServer& server = this->StartServer();
  EXPECT_EQ(server.GetAccessToken().size(), 32u);
  HttpResult result;
  std::string reason;
  ASSERT_TRUE(HttpGet("127.0.0.1", server.GetPort(), "/", false, {}, &result, &reason)) << reason;
  EXPECT_EQ(result.status, 403);
  EXPECT_NE(result.body.find("access token"), std::string::npos);
  ASSERT_TRUE(HttpGet("127.0.0.1", server.GetPort(), "/?token=0123456789abcdef0123456789abcdef", false,
    {}, &result, &reason));
  EXPECT_EQ(result.status, 403);

  ASSERT_TRUE(HttpGet("127.0.0.1", server.GetPort(), "/?token=" + server.GetAccessToken(), false, {},
    &result, &reason));
  EXPECT_EQ(result.status, 200);
  EXPECT_NE(result.body.find("player"), std::string::npos);
  EXPECT_EQ(result.headers["content-type"], "text/html; charset=utf-8");
  const std::string cookie = result.headers["set-cookie"];
  EXPECT_NE(cookie.find("holovolume_token=" + server.GetAccessToken()), std::string::npos);
  EXPECT_NE(cookie.find("HttpOnly"), std::string::npos);
  EXPECT_NE(cookie.find("SameSite=Strict"), std::string::npos);
  EXPECT_EQ(cookie.find("Secure"), std::string::npos); // plain HTTP

  // The page's module imports carry the cookie instead of the query.
  const std::map<std::string, std::string> withCookie = { { "cookie",
    "theme=dark; holovolume_token=" + server.GetAccessToken() } };
  ASSERT_TRUE(HttpGet("127.0.0.1", server.GetPort(), "/lib/player.js", false, withCookie, &result, &reason));
  EXPECT_EQ(result.status, 200);
  EXPECT_EQ(result.headers["content-type"], "text/javascript; charset=utf-8");

  // Nothing outside the web root, nothing of an unknown type.
  for (const char* path : { "/../../etc/passwd", "/lib/../../x.js", "/notes.txt", "/%2e%2e/x.js" })
  {
    ASSERT_TRUE(HttpGet("127.0.0.1", server.GetPort(), path, false, withCookie, &result, &reason));
    EXPECT_EQ(result.status, 404) << path;
  }
  EXPECT_GE(server.GetCounters().rejectedRequests, 2u);
}

TEST_F(ServerTest, RefusesToListenOnTheNetworkUnlessAllowed)
{
  ServerOptions options;
  options.bindAddress = "0.0.0.0";
  options.webRoot = this->WebRoot.string();
  options.port = 0;
  RemotingServer server(options);
  std::string reason;
  EXPECT_FALSE(server.Start(&reason));
  EXPECT_NE(reason.find("--allow-remote"), std::string::npos) << reason;

  options.allowRemoteConnections = true;
  RemotingServer allowed(options);
  EXPECT_TRUE(allowed.Start(&reason)) << reason;
  EXPECT_NE(allowed.GetUrl().find("?token=" + allowed.GetAccessToken()), std::string::npos);

  options.webRoot = (this->WebRoot / "missing").string();
  RemotingServer noPage(options);
  EXPECT_FALSE(noPage.Start(&reason));
  EXPECT_NE(reason.find("index.html"), std::string::npos) << reason;
}

TEST_F(ServerTest, WebSocketUpgradeNeedsTheToken)
{
  RemotingServer& server = this->StartServer();
  RemotingClient client;
  std::string reason;
  EXPECT_FALSE(client.Connect("127.0.0.1", server.GetPort(), "/ws", false, &reason));
  EXPECT_NE(reason.find("403"), std::string::npos) << reason;
  EXPECT_FALSE(client.Connect("127.0.0.1", server.GetPort(), "/ws?token=wrong", false, &reason));
  EXPECT_TRUE(client.Connect("127.0.0.1", server.GetPort(), this->Target(), false, &reason)) << reason;
}

TEST_F(ServerTest, OneControllerSpectatorsFollowAndPosesReachTheRenderLoop)
{
  RemotingServer& server = this->StartServer();
  RemotingClient controller, spectator, second;
  EXPECT_EQ(this->Join(controller, Role::Controller).role, Role::Controller);
  EXPECT_EQ(this->Join(spectator, Role::Spectator).role, Role::Spectator);
  // A second would-be controller becomes a spectator.
  EXPECT_EQ(this->Join(second, Role::Controller).role, Role::Spectator);

  std::string reason;
  ASSERT_TRUE(controller.SendText(SerializePose(MakePose(3, 0.0)), &reason));
  ASSERT_TRUE(controller.SendText(SerializePose(MakePose(4, 0.1)), &reason));
  PoseMessage pose;
  ASSERT_TRUE(this->WaitForPose(&pose));
  // Poses may have been taken one by one or only the newest: either way, 4 arrives last.
  while (pose.poseId < 4 && this->WaitForPose(&pose))
  {
  }
  EXPECT_EQ(pose.poseId, 4u);
  EXPECT_DOUBLE_EQ(pose.eyes[1].view[12], -0.1 - 0.032);
  // An older pose after a newer one is ignored.
  ASSERT_TRUE(controller.SendText(SerializePose(MakePose(2, 0.5)), &reason));
  ASSERT_TRUE(controller.SendText(SerializeDisplayed({ 1, 4, 77.0 }), &reason));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_FALSE(server.TakeNewestPose(&pose));

  // A spectator's pose is refused, and the spectator stays connected.
  ASSERT_TRUE(spectator.SendText(SerializePose(MakePose(9, 0.0)), &reason));
  EXPECT_NE(this->NextText(spectator, "error").reason.find("spectator"), std::string::npos);
  EXPECT_FALSE(server.TakeNewestPose(&pose));

  server.Publish(MakeFrame(1, 4, 1000));
  for (RemotingClient* client : { &controller, &spectator, &second })
  {
    std::string message;
    RemotingClient::Received kind;
    while ((kind = client->Receive(&message, 5.0, &reason)) == RemotingClient::Received::Text)
    {
    }
    ASSERT_EQ(kind, RemotingClient::Received::Binary) << reason;
    FrameHeader header;
    EyeImage eyes[2];
    ASSERT_TRUE(DecodeFrameMessage(message, &header, eyes, &reason)) << reason;
    EXPECT_EQ(header.poseId, 4u);
    EXPECT_EQ(eyes[0].data.size(), 1000u);
  }
  const ServerCounters counters = server.GetCounters();
  EXPECT_EQ(counters.clients, 3);
  EXPECT_EQ(counters.spectators, 2);
  EXPECT_DOUBLE_EQ(counters.poseToDisplayMs, 77.0);

  // The controller leaves; the next client asking for control gets it.
  controller.Close();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_FALSE(server.GetCounters().hasController);
  RemotingClient successor;
  EXPECT_EQ(this->Join(successor, Role::Controller).role, Role::Controller);
  ASSERT_TRUE(successor.SendText(SerializePose(MakePose(0, 0.2)), &reason));
  ASSERT_TRUE(this->WaitForPose(&pose)); // pose ids restart with the new controller
  EXPECT_EQ(pose.poseId, 0u);
}

TEST_F(ServerTest, MalformedMessagesAreRejectedAndTheConnectionStaysHealthy)
{
  RemotingServer& server = this->StartServer();
  RemotingClient client;
  std::string reason;
  ASSERT_TRUE(client.Connect("127.0.0.1", server.GetPort(), this->Target(), false, &reason)) << reason;
  // Before hello, nothing else is accepted.
  ASSERT_TRUE(client.SendText(SerializePose(MakePose(1, 0)), &reason));
  EXPECT_NE(this->NextText(client, "error").reason.find("first message must be hello"), std::string::npos);
  HelloMessage hello;
  hello.protocol = 1;
  ASSERT_TRUE(client.SendText(SerializeHello(hello), &reason));
  this->NextText(client, "welcome");

  ASSERT_TRUE(client.SendText("{\"type\":\"pose\",\"poseId\":", &reason));
  EXPECT_EQ(this->NextText(client, "error").reason, "not valid JSON");
  ASSERT_TRUE(client.SendBinary(std::string("\x00\x01\x02", 3), &reason));
  EXPECT_NE(this->NextText(client, "error").reason.find("binary"), std::string::npos);
  ASSERT_TRUE(client.SendText(R"({"type":"interaction","action":"explode"})", &reason));
  EXPECT_NE(this->NextText(client, "error").reason.find("explode"), std::string::npos);

  // Still healthy: a ping is answered and a pose reaches the render loop.
  ASSERT_TRUE(client.SendText(R"({"type":"ping","clientTime":12.5})", &reason));
  EXPECT_DOUBLE_EQ(this->NextText(client, "pong").clientTime, 12.5);
  ASSERT_TRUE(client.SendText(SerializePose(MakePose(5, 0)), &reason));
  PoseMessage pose;
  ASSERT_TRUE(this->WaitForPose(&pose));
  EXPECT_EQ(server.GetCounters().rejectedMessages, 4u);
  std::lock_guard<std::mutex> lock(this->LogMutex);
  EXPECT_NE(this->Log.find("rejected a message: not valid JSON"), std::string::npos) << this->Log;
}

TEST_F(ServerTest, OversizedMessagesCloseTheConnectionWithCode1009)
{
  ServerOptions options;
  options.maximumMessageBytes = 4096;
  RemotingServer& server = this->StartServer(options);
  RemotingClient client;
  this->Join(client, Role::Controller);
  std::string reason, message;
  ASSERT_TRUE(client.SendText("{\"type\":\"ping\",\"pad\":\"" + std::string(5000, 'x') + "\"}", &reason));
  RemotingClient::Received kind;
  while ((kind = client.Receive(&message, 5.0, &reason)) == RemotingClient::Received::Text)
  {
  }
  EXPECT_EQ(kind, RemotingClient::Received::Closed);
  EXPECT_EQ(client.GetCloseCode(), 1009);
  // The server itself is fine.
  RemotingClient next;
  EXPECT_EQ(this->Join(next, Role::Controller).type, "welcome");
  (void)server;
}

TEST_F(ServerTest, AnotherProtocolVersionIsRefusedWithCode1002)
{
  this->StartServer();
  RemotingClient client;
  std::string reason, message;
  ASSERT_TRUE(client.Connect("127.0.0.1", this->Server->GetPort(), this->Target(), false, &reason));
  ASSERT_TRUE(client.SendText(R"({"type":"hello","protocol":2})", &reason));
  EXPECT_NE(this->NextText(client, "error").reason.find("speaks protocol 1, not 2"), std::string::npos);
  RemotingClient::Received kind;
  while ((kind = client.Receive(&message, 5.0, &reason)) == RemotingClient::Received::Text)
  {
  }
  EXPECT_EQ(kind, RemotingClient::Received::Closed);
  EXPECT_EQ(client.GetCloseCode(), 1002);
}

TEST_F(ServerTest, ASlowClientGetsTheNewestFrameAndNeverBlocksPublishing)
{
  RemotingServer& server = this->StartServer();
  RemotingClient slow;
  this->Join(slow, Role::Controller);
  // 40 frames of 4 MiB: far more than the socket buffers hold while nobody reads.
  const int frames = 40;
  std::vector<PublishedFrame> published;
  for (int i = 1; i <= frames; ++i)
  {
    published.push_back(MakeFrame(i, i, 2u << 20));
  }
  const auto start = std::chrono::steady_clock::now();
  for (const PublishedFrame& frame : published)
  {
    server.Publish(frame);
  }
  const double publishMs =
    std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  // A blocking publish would never return (nobody reads); 1 s leaves room for a loaded machine.
  EXPECT_LT(publishMs, 1000.0) << "publishing waited for the client";
  std::this_thread::sleep_for(std::chrono::milliseconds(300));

  int received = 0;
  std::uint64_t lastFrameId = 0;
  std::string message, reason;
  RemotingClient::Received kind;
  while ((kind = slow.Receive(&message, 1.0, &reason)) != RemotingClient::Received::Timeout)
  {
    ASSERT_NE(kind, RemotingClient::Received::Failed) << reason;
    ASSERT_NE(kind, RemotingClient::Received::Closed);
    if (kind == RemotingClient::Received::Binary)
    {
      FrameHeader header;
      EyeImage eyes[2];
      ASSERT_TRUE(DecodeFrameMessage(message, &header, eyes, &reason)) << reason;
      EXPECT_GT(header.frameId, lastFrameId); // in order, never stale after newer
      lastFrameId = header.frameId;
      ++received;
    }
  }
  EXPECT_EQ(lastFrameId, static_cast<std::uint64_t>(frames)) << "the newest frame must arrive";
  EXPECT_LT(received, frames / 2) << "stale frames were queued";
  EXPECT_GE(server.GetCounters().droppedFrames, static_cast<std::uint64_t>(frames - received));
}

TEST_F(ServerTest, H264ClientsWaitForAKeyFrameAndTheServerIsAskedForOne)
{
  ServerOptions options;
  options.codec = Codec::H264;
  RemotingServer& server = this->StartServer(options);
  server.TakeKeyFrameRequest();
  RemotingClient jpegOnly, h264;
  EXPECT_EQ(this->Join(jpegOnly, Role::Spectator, false).codec, Codec::Jpeg);
  EXPECT_EQ(this->Join(h264, Role::Controller, true).codec, Codec::H264);
  EXPECT_TRUE(server.NeedsCodec(Codec::H264));
  EXPECT_TRUE(server.NeedsCodec(Codec::Jpeg));
  EXPECT_TRUE(server.TakeKeyFrameRequest());
  EXPECT_FALSE(server.TakeKeyFrameRequest());

  // A delta frame first: the joining H.264 client cannot use it and must not get it.
  server.Publish(MakeFrame(1, 1, 100, true, false));
  server.Publish(MakeFrame(2, 1, 100, true, true));
  std::string message, reason;
  RemotingClient::Received kind;
  while ((kind = h264.Receive(&message, 5.0, &reason)) == RemotingClient::Received::Text)
  {
  }
  ASSERT_EQ(kind, RemotingClient::Received::Binary) << reason;
  FrameHeader header;
  EyeImage eyes[2];
  ASSERT_TRUE(DecodeFrameMessage(message, &header, eyes, &reason)) << reason;
  EXPECT_EQ(header.frameId, 2u);
  EXPECT_TRUE(header.keyFrame);
}

// A browser reads its socket at once and queues what it cannot decode yet, so a renderer
// faster than the page would build seconds of latency there. A client that acknowledges
// frames has at most the window unacknowledged; the newest frame waits for room.
TEST_F(ServerTest, AnAcknowledgingClientHasAtMostTheWindowOfFramesInFlight)
{
  RemotingClient client;
  RemotingServer& server = this->StartWithFlowControl(client, 2, 600.0);
  for (std::uint64_t id = 1; id <= 10; ++id)
  {
    server.Publish(MakeFrame(id, id, 1000));
    ASSERT_TRUE(server.Flush());
  }
  EXPECT_EQ(this->NextFrameId(client, 5.0), 1u);
  EXPECT_EQ(this->NextFrameId(client, 5.0), 2u);
  EXPECT_EQ(this->NextFrameId(client, 0.5), 0u) << "a third frame while two are unacknowledged";

  this->Acknowledge(client, 1);
  EXPECT_EQ(this->NextFrameId(client, 5.0), 10u) << "room for one: the newest frame";
  EXPECT_EQ(this->NextFrameId(client, 0.5), 0u);

  // Acknowledgements are cumulative: 10 covers 2.
  this->Acknowledge(client, 10);
  server.Publish(MakeFrame(11, 11, 1000));
  EXPECT_EQ(this->NextFrameId(client, 5.0), 11u);
  server.Publish(MakeFrame(12, 12, 1000));
  EXPECT_EQ(this->NextFrameId(client, 5.0), 12u) << "two fit in the window";
  EXPECT_GE(server.GetCounters().droppedFrames, 7u);
}

// A decoder that lost a frame never acknowledges it; the window must not stay shut.
TEST_F(ServerTest, AnUnacknowledgedFrameStopsHoldingTheWindowAfterTheTimeout)
{
  RemotingClient client;
  RemotingServer& server = this->StartWithFlowControl(client, 1, 1.0);
  server.Publish(MakeFrame(1, 1, 1000));
  EXPECT_EQ(this->NextFrameId(client, 5.0), 1u);
  server.Publish(MakeFrame(2, 2, 1000));
  EXPECT_EQ(this->NextFrameId(client, 0.3), 0u) << "the window of one is full";
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  server.Publish(MakeFrame(3, 3, 1000)); // any event after the timeout lets the newest through
  EXPECT_EQ(this->NextFrameId(client, 5.0), 3u);
}

// An H.264 client slower than the renderer: a delta frame cannot replace the one waiting for
// it, so the waiting frame is kept, deltas are skipped and a key frame is requested; every
// frame the client gets decodes, and it keeps getting frames.
TEST_F(ServerTest, ASlowH264ClientGetsOnlyDecodableFramesAndKeepsGettingThem)
{
  RemotingClient client;
  RemotingServer& server = this->StartWithFlowControl(client, 1, 600.0, Codec::H264);
  server.TakeKeyFrameRequest();
  const auto publish = [&](std::uint64_t id, bool key) {
    server.Publish(MakeFrame(id, id, 100, true, key));
    ASSERT_TRUE(server.Flush());
  };
  publish(1, true);
  EXPECT_EQ(this->NextFrameId(client, 5.0), 1u);
  publish(2, false); // waits: decodes after 1
  EXPECT_FALSE(server.TakeKeyFrameRequest());
  publish(3, false); // refers to 2, which the client has not had: skipped
  EXPECT_TRUE(server.TakeKeyFrameRequest()) << "the encoder must be asked for a key frame";
  this->Acknowledge(client, 1);
  EXPECT_EQ(this->NextFrameId(client, 5.0), 2u) << "the waiting delta is kept, not lost";
  publish(4, false); // after a skipped delta: useless without a key frame
  this->Acknowledge(client, 2);
  EXPECT_EQ(this->NextFrameId(client, 0.5), 0u);
  publish(5, true);
  EXPECT_EQ(this->NextFrameId(client, 5.0), 5u);
  publish(6, true);
  publish(7, false); // 6 is still waiting for the window: 7 cannot replace it
  this->Acknowledge(client, 5);
  EXPECT_EQ(this->NextFrameId(client, 5.0), 6u);
  this->Acknowledge(client, 6);
  EXPECT_EQ(this->NextFrameId(client, 0.5), 0u);
}

TEST_F(ServerTest, ServesHttpsAndWssWithAUserCertificate)
{
  const fs::path key = this->WebRoot / "key.pem", certificate = this->WebRoot / "certificate.pem";
  const std::string command = "openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj /CN=localhost -keyout '" +
    key.string() + "' -out '" + certificate.string() + "' >/dev/null 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << "the test needs the openssl command";
  ServerOptions options;
  options.certificateFile = certificate.string();
  options.privateKeyFile = key.string();
  RemotingServer& server = this->StartServer(options);
  EXPECT_TRUE(server.UsesTls());
  EXPECT_EQ(server.GetUrl().substr(0, 8), "https://");
  HttpResult result;
  std::string reason;
  ASSERT_TRUE(HttpGet("127.0.0.1", server.GetPort(), "/?token=" + server.GetAccessToken(), true, {},
    &result, &reason))
    << reason;
  EXPECT_EQ(result.status, 200);
  EXPECT_NE(result.headers["set-cookie"].find("Secure"), std::string::npos);
  RemotingClient client;
  EXPECT_EQ(this->Join(client, Role::Controller, false, true).type, "welcome");
  // Plain HTTP to the TLS port gets nothing.
  EXPECT_FALSE(HttpGet("127.0.0.1", server.GetPort(), "/?token=" + server.GetAccessToken(), false, {},
                 &result, &reason) &&
    result.status == 200);

  ServerOptions broken;
  broken.certificateFile = (this->WebRoot / "nothing.pem").string();
  broken.privateKeyFile = key.string();
  broken.webRoot = this->WebRoot.string();
  broken.port = 0;
  RemotingServer refused(broken);
  EXPECT_FALSE(refused.Start(&reason));
  EXPECT_NE(reason.find("certificate"), std::string::npos) << reason;
}
