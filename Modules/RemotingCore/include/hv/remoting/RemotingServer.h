// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// The HTTP(S) + WebSocket server of the remoting protocol (Documentation/RemotingProtocol.md),
// on Boost.Beast. It runs its own network thread; the render loop talks to it through
// thread-safe calls: take the newest pose and the queued interactions, publish an encoded
// frame (latest wins: a client that is still sending, or that acknowledges decoded frames and
// has the window in flight, gets only the newest frame next), publish statistics. A slow
// client never blocks the caller.
#ifndef hv_remoting_RemotingServer_h
#define hv_remoting_RemotingServer_h

#include "hv/remoting/Protocol.h"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace hv
{
namespace remoting
{
struct ServerOptions
{
  // Loopback by default; any other address needs allowRemoteConnections.
  std::string bindAddress = "127.0.0.1";
  unsigned short port = 8080; // 0: any free port (GetPort() tells which)
  bool allowRemoteConnections = false;
  // Checked on every HTTP request and WebSocket upgrade; empty: a random 128-bit token.
  std::string accessToken;
  // Both set: HTTPS and WSS with this PEM certificate (chain) and private key.
  std::string certificateFile;
  std::string privateKeyFile;
  // The directory the player page is served from.
  std::string webRoot;
  std::size_t maximumMessageBytes = DefaultMaximumClientMessageBytes;
  // The codec clients get when they can decode it (JPEG otherwise).
  Codec codec = Codec::Jpeg;
  // Flow control for clients that acknowledge frames with `decoded` messages: at most this
  // many frames sent and not yet acknowledged. A browser reads its socket at once and queues
  // frames in its decoder, so TCP back-pressure alone would let seconds of frames pile up there.
  int maximumFramesInFlight = 2;
  // An unacknowledged frame older than this no longer holds the window (a lost decoder output
  // must not freeze the view).
  double frameAcknowledgementTimeoutSeconds = 2.0;
  // Called from the network thread with one line per event worth logging (rejected
  // requests and messages, connections); nullptr: silent.
  std::function<void(const std::string&)> log;
};

// One frame, encoded once per codec some client needs; each is a complete HVF1 message.
struct PublishedFrame
{
  std::uint64_t frameId = 0; // the frame header's, for flow control
  std::shared_ptr<const std::string> jpegMessage;
  std::shared_ptr<const std::string> h264Message;
  bool h264KeyFrame = false;
};

struct ServerCounters
{
  int clients = 0;
  int spectators = 0;
  bool hasController = false;
  std::uint64_t posesReceived = 0;
  std::uint64_t interactionsReceived = 0;
  std::uint64_t rejectedMessages = 0;
  std::uint64_t rejectedRequests = 0;
  std::uint64_t framesSent = 0;
  std::uint64_t droppedFrames = 0;
  double poseToDisplayMs = 0.0; // the controller's latest report, 0 before one
};

class RemotingServer
{
public:
  explicit RemotingServer(ServerOptions options);
  ~RemotingServer();
  RemotingServer(const RemotingServer&) = delete;
  RemotingServer& operator=(const RemotingServer&) = delete;

  // Binds and starts the network thread. False with a reason that says what to change.
  bool Start(std::string* reason);
  void Stop();
  bool IsRunning() const;
  unsigned short GetPort() const;
  const std::string& GetAccessToken() const;
  bool UsesTls() const;
  // The address to open in a browser, token included.
  std::string GetUrl() const;

  // What welcome messages say; call before Start() and whenever it changes.
  void SetWelcome(const WelcomeInfo& welcome);

  // The controller's newest pose, if newer than the last one taken.
  bool TakeNewestPose(PoseMessage* pose);
  std::vector<InteractionMessage> TakeInteractions();
  // Blocks up to `seconds` until a pose, an interaction or a new client arrives.
  void WaitForActivity(double seconds);

  // Whether a connected client receives this codec.
  bool NeedsCodec(Codec codec) const;
  // True once after an H.264 client joined or lost a frame: encode the next frame as a key frame.
  bool TakeKeyFrameRequest();
  void Publish(const PublishedFrame& frame);
  // Publish() returns at once; this waits until the network thread has handed everything
  // published before the call to the clients' sessions (not until it reached them). False if
  // the server is not running or the timeout passed.
  bool Flush(double timeoutSeconds = 5.0);
  // Sends each client a stats message (its own send time and dropped frames filled in).
  void PublishStatistics(const ServerStatistics& statistics);
  ServerCounters GetCounters() const;

  struct Internals;

private:
  std::shared_ptr<Internals> Impl;
};

// A random token of 128 bits as 32 hexadecimal digits (OpenSSL's RAND_bytes).
std::string GenerateAccessToken();
}
}

#endif
