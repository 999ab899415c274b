// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/remoting/RemotingServer.h"

#include <boost/asio/ip/host_name.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/beast/websocket/ssl.hpp>

#include <openssl/crypto.h>
#include <openssl/rand.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <fstream>
#include <future>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

namespace hv
{
namespace remoting
{
namespace beast = boost::beast;
namespace http = boost::beast::http;
namespace websocket = boost::beast::websocket;
namespace net = boost::asio;
namespace ssl = boost::asio::ssl;
using tcp = boost::asio::ip::tcp;

namespace
{
constexpr std::size_t MaximumHeaderBytes = 8192;
constexpr std::size_t MaximumQueuedTextMessages = 64;
constexpr std::size_t MaximumQueuedInteractions = 256;
const char* const TokenCookie = "holovolume_token";

double NowMs()
{
  using namespace std::chrono;
  return duration<double, std::milli>(steady_clock::now().time_since_epoch()).count();
}

// Constant-time comparison, so the token cannot be guessed byte by byte from timing.
bool TokenMatches(std::string_view candidate, const std::string& token)
{
  return candidate.size() == token.size() &&
    CRYPTO_memcmp(candidate.data(), token.data(), token.size()) == 0;
}

std::string_view QueryParameter(std::string_view target, std::string_view name)
{
  const std::size_t question = target.find('?');
  if (question == std::string_view::npos)
  {
    return {};
  }
  std::string_view query = target.substr(question + 1);
  while (!query.empty())
  {
    const std::size_t amp = query.find('&');
    const std::string_view pair = query.substr(0, amp);
    if (pair.size() > name.size() && pair.substr(0, name.size()) == name && pair[name.size()] == '=')
    {
      return pair.substr(name.size() + 1);
    }
    query = amp == std::string_view::npos ? std::string_view() : query.substr(amp + 1);
  }
  return {};
}

std::string_view CookieValue(std::string_view cookies, std::string_view name)
{
  while (!cookies.empty())
  {
    const std::size_t semicolon = cookies.find(';');
    std::string_view pair = cookies.substr(0, semicolon);
    while (!pair.empty() && pair.front() == ' ')
    {
      pair.remove_prefix(1);
    }
    if (pair.size() > name.size() && pair.substr(0, name.size()) == name && pair[name.size()] == '=')
    {
      return pair.substr(name.size() + 1);
    }
    cookies = semicolon == std::string_view::npos ? std::string_view() : cookies.substr(semicolon + 1);
  }
  return {};
}

const char* MimeType(std::string_view path)
{
  const std::size_t dot = path.rfind('.');
  const std::string_view extension = dot == std::string_view::npos ? "" : path.substr(dot);
  if (extension == ".html")
    return "text/html; charset=utf-8";
  if (extension == ".js" || extension == ".mjs")
    return "text/javascript; charset=utf-8";
  if (extension == ".css")
    return "text/css; charset=utf-8";
  if (extension == ".json")
    return "application/json";
  if (extension == ".png")
    return "image/png";
  if (extension == ".svg")
    return "image/svg+xml";
  return nullptr;
}

// Maps a request path to a file under the web root: only [A-Za-z0-9._-/] and no "..", so no
// request can leave the directory; "/" is the player page.
bool SafeRelativePath(std::string_view target, std::string* path)
{
  std::string_view clean = target.substr(0, target.find('?'));
  if (clean.empty() || clean.front() != '/')
  {
    return false;
  }
  clean.remove_prefix(1);
  if (clean.empty())
  {
    *path = "index.html";
    return true;
  }
  if (clean.size() > 200 || clean.find("..") != std::string_view::npos || clean.front() == '/')
  {
    return false;
  }
  for (char c : clean)
  {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-' || c == '/'))
    {
      return false;
    }
  }
  *path = std::string(clean);
  return true;
}

bool IsLoopback(const net::ip::address& address)
{
  return address.is_loopback();
}
}

// A connected WebSocket client as the server core sees it, whatever its transport.
class ClientSession
{
public:
  virtual ~ClientSession() = default;
  virtual void QueueFrame(const PublishedFrame& frame, double publishedMs) = 0;
  virtual void QueueStatistics(ServerStatistics statistics) = 0;
  // The client acknowledged every frame up to frameId (a `decoded` message).
  virtual void FramesDecoded(std::uint64_t frameId) = 0;
  Role SessionRole = Role::Spectator;
  bool Greeted = false;
  Codec SessionCodec = Codec::Jpeg;
  // Touched on the network thread only.
  bool NeedsKeyFrame = true;
  std::uint64_t Dropped = 0;
  double LastSendMs = 0.0;
  int Id = 0;
};

struct RemotingServer::Internals : std::enable_shared_from_this<RemotingServer::Internals>
{
  ServerOptions Options;
  // One network thread: handlers never run concurrently, so sessions need no locks of their
  // own; the mutex guards what the render thread shares with them.
  std::unique_ptr<net::io_context> Io = std::make_unique<net::io_context>(1);
  std::unique_ptr<ssl::context> TlsContext;
  std::unique_ptr<tcp::acceptor> Acceptor;
  std::thread NetworkThread;
  std::atomic<bool> Running{ false };
  unsigned short Port = 0;

  mutable std::mutex Mutex;
  std::condition_variable Activity;
  WelcomeInfo Welcome;
  std::vector<std::weak_ptr<ClientSession>> Sessions;
  ClientSession* Controller = nullptr;
  PoseMessage NewestPose;
  bool HasNewPose = false;
  std::uint64_t LastPoseId = 0;
  bool AnyPose = false;
  std::deque<InteractionMessage> Interactions;
  bool KeyFrameRequested = false;
  bool ActivitySignalled = false;
  ServerCounters Counters;
  int NextSessionId = 1;

  void Log(const std::string& line) const
  {
    if (this->Options.log)
    {
      this->Options.log(line);
    }
  }

  void Signal()
  {
    this->ActivitySignalled = true;
    this->Activity.notify_all();
  }

  void Accept();
  template <class Stream>
  void StartHttp(Stream stream);

  // Called by sessions on the network thread.
  void Register(const std::shared_ptr<ClientSession>& session)
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    session->Id = this->NextSessionId++;
    this->Sessions.push_back(session);
  }

  void Unregister(ClientSession* session)
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    if (this->Controller == session)
    {
      this->Controller = nullptr;
      this->AnyPose = false;
      this->Log("client " + std::to_string(session->Id) + ": the controller left");
    }
    this->Sessions.erase(std::remove_if(this->Sessions.begin(), this->Sessions.end(),
                           [session](const std::weak_ptr<ClientSession>& weak) {
                             const auto locked = weak.lock();
                             return !locked || locked.get() == session;
                           }),
      this->Sessions.end());
    this->Signal();
  }

  // Handles a parsed message; returns the text to send back ("" for none).
  std::string Handle(ClientSession& session, const ClientMessage& message, bool* closeProtocol);
};

template <class Stream>
class WebSocketSession
  : public ClientSession
  , public std::enable_shared_from_this<WebSocketSession<Stream>>
{
public:
  WebSocketSession(std::shared_ptr<RemotingServer::Internals> server, Stream&& stream)
    : Server(std::move(server))
    , Socket(std::move(stream))
  {
  }

  ~WebSocketSession() override
  {
    if (this->Registered)
    {
      this->Server->Unregister(this);
    }
  }

  void Run(http::request<http::string_body> request)
  {
    this->Socket.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    this->Socket.read_message_max(this->Server->Options.maximumMessageBytes);
    this->Socket.set_option(websocket::stream_base::decorator([](websocket::response_type& response) {
      response.set(http::field::server, "HoloVolume");
    }));
    this->Socket.async_accept(request,
      [self = this->shared_from_this()](beast::error_code error) { self->OnAccept(error); });
  }

  void QueueFrame(const PublishedFrame& frame, double publishedMs) override
  {
    if (!this->Greeted)
    {
      return;
    }
    const bool h264 = this->SessionCodec == Codec::H264;
    std::shared_ptr<const std::string> message = h264 ? frame.h264Message : frame.jpegMessage;
    if (!message)
    {
      return;
    }
    if (h264 && this->NeedsKeyFrame && !frame.h264KeyFrame)
    {
      return; // the client could not decode it; a key frame was requested
    }
    if (this->PendingFrame)
    {
      // Latest wins: the frame still waiting is replaced. An H.264 delta frame cannot replace
      // it, because it refers to the waiting one, which the client has not had: the waiting
      // frame stays (it decodes), this one is dropped, and the client skips deltas until a key
      // frame, which can replace anything. Were the waiting frame dropped instead, a client
      // slower than the renderer would lose every frame to the next delta and see none.
      ++this->Dropped;
      this->CountDropped();
      if (h264 && !frame.h264KeyFrame)
      {
        this->NeedsKeyFrame = true;
        this->RequestKeyFrame();
        return;
      }
    }
    if (h264 && frame.h264KeyFrame)
    {
      this->NeedsKeyFrame = false;
    }
    this->PendingFrame = std::move(message);
    this->PendingFrameId = frame.frameId;
    this->PendingPublishedMs = publishedMs;
    this->Write();
  }

  void FramesDecoded(std::uint64_t frameId) override
  {
    this->FlowControl = true;
    while (!this->FramesInFlight.empty() && this->FramesInFlight.front().first <= frameId)
    {
      this->FramesInFlight.pop_front();
    }
    this->Write();
  }

  void QueueStatistics(ServerStatistics statistics) override
  {
    if (!this->Greeted)
    {
      return;
    }
    statistics.sendMs = this->LastSendMs;
    statistics.droppedFrames = this->Dropped;
    this->QueueText(SerializeStats(statistics));
  }

private:
  void OnAccept(beast::error_code error)
  {
    if (error)
    {
      this->Server->Log(std::string("WebSocket handshake failed: ") + error.message());
      return;
    }
    this->Server->Register(this->shared_from_this());
    this->Registered = true;
    this->Server->Log("client " + std::to_string(this->Id) + ": connected");
    this->Read();
  }

  void Read()
  {
    this->Socket.async_read(this->Buffer,
      [self = this->shared_from_this()](beast::error_code error, std::size_t) { self->OnRead(error); });
  }

  void OnRead(beast::error_code error)
  {
    if (error)
    {
      if (error == websocket::error::message_too_big)
      {
        this->Server->Log("client " + std::to_string(this->Id) + ": message larger than " +
          std::to_string(this->Server->Options.maximumMessageBytes) + " bytes, connection closed");
      }
      else if (error != websocket::error::closed && error != net::error::operation_aborted)
      {
        this->Server->Log("client " + std::to_string(this->Id) + ": " + error.message());
      }
      return;
    }
    std::string reply;
    bool closeProtocol = false;
    if (!this->Socket.got_text())
    {
      reply = this->Reject("binary messages are not part of the protocol");
    }
    else
    {
      const std::string text = beast::buffers_to_string(this->Buffer.data());
      ClientMessage message;
      std::string reason;
      if (ParseClientMessage(text, &message, &reason))
      {
        reply = this->Server->Handle(*this, message, &closeProtocol);
      }
      else
      {
        reply = this->Reject(reason);
      }
    }
    this->Buffer.consume(this->Buffer.size());
    if (!reply.empty())
    {
      this->QueueText(std::move(reply));
    }
    if (closeProtocol)
    {
      this->CloseAfterWrites = true;
      this->Write();
      return;
    }
    this->Read();
  }

  std::string Reject(const std::string& reason)
  {
    {
      std::lock_guard<std::mutex> lock(this->Server->Mutex);
      ++this->Server->Counters.rejectedMessages;
    }
    this->Server->Log("client " + std::to_string(this->Id) + ": rejected a message: " + reason);
    return SerializeError(reason);
  }

  void CountDropped()
  {
    std::lock_guard<std::mutex> lock(this->Server->Mutex);
    ++this->Server->Counters.droppedFrames;
  }

  void RequestKeyFrame()
  {
    std::lock_guard<std::mutex> lock(this->Server->Mutex);
    this->Server->KeyFrameRequested = true;
  }

  void QueueText(std::string text)
  {
    if (this->Texts.size() >= MaximumQueuedTextMessages)
    {
      this->Texts.pop_front(); // a client that reads nothing loses old status messages
    }
    this->Texts.push_back(std::move(text));
    this->Write();
  }

  void Write()
  {
    if (this->Writing)
    {
      return;
    }
    if (!this->Texts.empty())
    {
      this->Writing = true;
      this->CurrentText = std::move(this->Texts.front());
      this->Texts.pop_front();
      this->Socket.text(true);
      this->Socket.async_write(net::buffer(this->CurrentText),
        [self = this->shared_from_this()](beast::error_code error, std::size_t) {
          self->OnWrite(error, false);
        });
    }
    else if (this->PendingFrame && this->MayWriteFrame())
    {
      this->Writing = true;
      if (this->FlowControl)
      {
        this->FramesInFlight.emplace_back(this->PendingFrameId, NowMs());
      }
      this->CurrentFrame = std::move(this->PendingFrame);
      this->CurrentPublishedMs = this->PendingPublishedMs;
      this->Socket.binary(true);
      this->Socket.async_write(net::buffer(*this->CurrentFrame),
        [self = this->shared_from_this()](beast::error_code error, std::size_t) {
          self->OnWrite(error, true);
        });
    }
    else if (this->CloseAfterWrites)
    {
      this->CloseAfterWrites = false;
      this->Socket.async_close(websocket::close_code::protocol_error,
        [self = this->shared_from_this()](beast::error_code) {});
    }
  }

  // A client that acknowledges frames gets a new one only while fewer than the window are
  // unacknowledged; the newest frame waits in PendingFrame meanwhile (latest wins). A client
  // that never acknowledges is paced by TCP alone.
  bool MayWriteFrame()
  {
    if (!this->FlowControl)
    {
      return true;
    }
    const double expiredBefore =
      NowMs() - 1000.0 * this->Server->Options.frameAcknowledgementTimeoutSeconds;
    while (!this->FramesInFlight.empty() && this->FramesInFlight.front().second < expiredBefore)
    {
      this->FramesInFlight.pop_front();
    }
    return this->FramesInFlight.size() <
      static_cast<std::size_t>(std::max(1, this->Server->Options.maximumFramesInFlight));
  }

  void OnWrite(beast::error_code error, bool frame)
  {
    this->Writing = false;
    if (error)
    {
      return; // the read side reports and ends the session
    }
    if (frame)
    {
      this->LastSendMs = NowMs() - this->CurrentPublishedMs;
      this->CurrentFrame.reset();
      std::lock_guard<std::mutex> lock(this->Server->Mutex);
      ++this->Server->Counters.framesSent;
    }
    this->Write();
  }

  std::shared_ptr<RemotingServer::Internals> Server;
  websocket::stream<Stream> Socket;
  beast::flat_buffer Buffer;
  std::deque<std::string> Texts;
  std::string CurrentText;
  std::shared_ptr<const std::string> PendingFrame;
  std::uint64_t PendingFrameId = 0;
  std::shared_ptr<const std::string> CurrentFrame;
  bool FlowControl = false; // set by the client's first `decoded` message
  std::deque<std::pair<std::uint64_t, double>> FramesInFlight; // frameId, sent at (ms)
  double PendingPublishedMs = 0.0;
  double CurrentPublishedMs = 0.0;
  bool Writing = false;
  bool CloseAfterWrites = false;
  bool Registered = false;
};

std::string RemotingServer::Internals::Handle(
  ClientSession& session, const ClientMessage& message, bool* closeProtocol)
{
  const std::string client = "client " + std::to_string(session.Id);
  std::unique_lock<std::mutex> lock(this->Mutex);
  const auto reject = [&](const std::string& reason) {
    ++this->Counters.rejectedMessages;
    lock.unlock();
    this->Log(client + ": rejected a message: " + reason);
    return SerializeError(reason);
  };
  if (message.type == ClientMessageType::Hello)
  {
    if (session.Greeted)
    {
      return reject("hello: already greeted");
    }
    if (message.hello.protocol != ProtocolVersion)
    {
      *closeProtocol = true;
      return reject("hello: this server speaks protocol " + std::to_string(ProtocolVersion) +
        ", not " + std::to_string(message.hello.protocol));
    }
    session.Greeted = true;
    session.SessionRole =
      message.hello.role == Role::Controller && !this->Controller ? Role::Controller : Role::Spectator;
    if (session.SessionRole == Role::Controller)
    {
      this->Controller = &session;
      this->AnyPose = false;
    }
    session.SessionCodec =
      this->Options.codec == Codec::H264 && message.hello.decodesH264 ? Codec::H264 : Codec::Jpeg;
    session.NeedsKeyFrame = true;
    if (session.SessionCodec == Codec::H264)
    {
      this->KeyFrameRequested = true;
    }
    this->Signal();
    const std::string welcome = SerializeWelcome(this->Welcome, session.SessionRole, session.SessionCodec);
    lock.unlock();
    this->Log(client + ": hello from '" + message.hello.client + "', " +
      (session.SessionRole == Role::Controller ? "controller" : "spectator") + ", " +
      CodecName(session.SessionCodec));
    return welcome;
  }
  if (!session.Greeted)
  {
    return reject("the first message must be hello");
  }
  switch (message.type)
  {
    case ClientMessageType::Pose:
      if (this->Controller != &session)
      {
        return reject("pose: only the controlling viewer sends poses; this client is a spectator");
      }
      // Out-of-order or repeated poses are ignored: the newest one wins.
      if (!this->AnyPose || message.pose.poseId > this->LastPoseId)
      {
        this->NewestPose = message.pose;
        this->LastPoseId = message.pose.poseId;
        this->AnyPose = true;
        this->HasNewPose = true;
        ++this->Counters.posesReceived;
        this->Signal();
      }
      return std::string();
    case ClientMessageType::Interaction:
      if (this->Controller != &session)
      {
        return reject("interaction: only the controlling viewer interacts; this client is a spectator");
      }
      if (this->Interactions.size() >= MaximumQueuedInteractions)
      {
        this->Interactions.pop_front();
      }
      this->Interactions.push_back(message.interaction);
      ++this->Counters.interactionsReceived;
      this->Signal();
      return std::string();
    case ClientMessageType::Displayed:
      if (this->Controller == &session)
      {
        this->Counters.poseToDisplayMs = message.displayed.poseToDisplayMs;
      }
      return std::string();
    case ClientMessageType::Decoded:
      lock.unlock();
      session.FramesDecoded(message.decoded.frameId); // on the network thread, like all of Handle
      return std::string();
    case ClientMessageType::Ping:
      return SerializePong(message.ping.clientTime);
    case ClientMessageType::Hello:
      break;
  }
  return std::string();
}

// One HTTP connection: serves the player's files and hands WebSocket upgrades over to a
// WebSocketSession. Every request needs the access token.
template <class Stream>
class HttpSession : public std::enable_shared_from_this<HttpSession<Stream>>
{
public:
  HttpSession(std::shared_ptr<RemotingServer::Internals> server, Stream&& stream)
    : Server(std::move(server))
    , Socket(std::move(stream))
  {
  }

  void Read()
  {
    this->Parser.emplace();
    this->Parser->header_limit(MaximumHeaderBytes);
    this->Parser->body_limit(1024);
    beast::get_lowest_layer(this->Socket).expires_after(std::chrono::seconds(30));
    http::async_read(this->Socket, this->Buffer, *this->Parser,
      [self = this->shared_from_this()](beast::error_code error, std::size_t) { self->OnRead(error); });
  }

private:
  void OnRead(beast::error_code error)
  {
    if (error)
    {
      if (error != http::error::end_of_stream && error != net::error::operation_aborted &&
        error != beast::error::timeout)
      {
        this->CountRejected(std::string("unreadable HTTP request: ") + error.message());
      }
      this->Close();
      return;
    }
    http::request<http::string_body> request = this->Parser->release();
    const std::string_view target(request.target().data(), request.target().size());
    const auto cookies = request[http::field::cookie];
    const std::string& token = this->Server->Options.accessToken;
    const bool queryToken = TokenMatches(QueryParameter(target, "token"), token);
    const bool cookieToken =
      TokenMatches(CookieValue(std::string_view(cookies.data(), cookies.size()), TokenCookie), token);
    if (!queryToken && !cookieToken)
    {
      this->CountRejected("request for '" + std::string(target.substr(0, target.find('?'))).substr(0, 64) +
        "' without a valid access token");
      return this->Respond(this->Error(request, http::status::forbidden,
        "HoloVolume: this address needs the access token the server printed at start "
        "(open the URL with ?token=...).\n"));
    }
    const std::string_view path = target.substr(0, target.find('?'));
    if (websocket::is_upgrade(request))
    {
      if (path != "/ws")
      {
        return this->Respond(this->Error(request, http::status::not_found, "WebSocket lives at /ws\n"));
      }
      // Browsers send Origin: a page from another site must not drive the viewer with the
      // cookie this site set (cross-site WebSocket hijacking).
      const auto origin = request[http::field::origin];
      const auto host = request[http::field::host];
      if (!origin.empty())
      {
        const std::string_view originText(origin.data(), origin.size());
        const std::size_t scheme = originText.find("://");
        const std::string_view originHost =
          scheme == std::string_view::npos ? originText : originText.substr(scheme + 3);
        if (originHost != std::string_view(host.data(), host.size()))
        {
          this->CountRejected("WebSocket upgrade from foreign origin '" +
            std::string(originText.substr(0, 64)) + "'");
          return this->Respond(
            this->Error(request, http::status::forbidden, "cross-origin WebSocket refused\n"));
        }
      }
      beast::get_lowest_layer(this->Socket).expires_never();
      std::make_shared<WebSocketSession<Stream>>(this->Server, std::move(this->Socket))
        ->Run(std::move(request));
      return;
    }
    if (request.method() != http::verb::get && request.method() != http::verb::head)
    {
      return this->Respond(
        this->Error(request, http::status::method_not_allowed, "only GET and HEAD\n"));
    }
    std::string relative;
    const char* mime = nullptr;
    if (!SafeRelativePath(target, &relative) || !(mime = MimeType(relative)))
    {
      this->CountRejected("refused path '" + std::string(path.substr(0, 64)) + "'");
      return this->Respond(this->Error(request, http::status::not_found, "not found\n"));
    }
    std::ifstream file(this->Server->Options.webRoot + "/" + relative, std::ios::binary);
    if (!file)
    {
      return this->Respond(this->Error(request, http::status::not_found, "not found\n"));
    }
    std::ostringstream content;
    content << file.rdbuf();
    http::response<http::string_body> response{ http::status::ok, request.version() };
    response.set(http::field::server, "HoloVolume");
    response.set(http::field::content_type, mime);
    response.set(http::field::cache_control, "no-store");
    response.set("X-Content-Type-Options", "nosniff");
    // The page's URL holds the token: never send it on as a referrer.
    response.set("Referrer-Policy", "no-referrer");
    if (queryToken)
    {
      response.set(http::field::set_cookie,
        std::string(TokenCookie) + "=" + token + "; Path=/; HttpOnly; SameSite=Strict" +
          (this->Server->TlsContext ? "; Secure" : ""));
    }
    response.keep_alive(request.keep_alive());
    if (request.method() == http::verb::head)
    {
      response.content_length(content.str().size());
    }
    else
    {
      response.body() = content.str();
      response.prepare_payload();
    }
    this->Respond(std::move(response));
  }

  http::response<http::string_body> Error(const http::request<http::string_body>& request,
    http::status status, const std::string& text)
  {
    http::response<http::string_body> response{ status, request.version() };
    response.set(http::field::server, "HoloVolume");
    response.set(http::field::content_type, "text/plain; charset=utf-8");
    response.keep_alive(false);
    response.body() = text;
    response.prepare_payload();
    return response;
  }

  void CountRejected(const std::string& reason)
  {
    {
      std::lock_guard<std::mutex> lock(this->Server->Mutex);
      ++this->Server->Counters.rejectedRequests;
    }
    this->Server->Log("rejected an HTTP request: " + reason);
  }

  void Respond(http::response<http::string_body>&& response)
  {
    auto shared = std::make_shared<http::response<http::string_body>>(std::move(response));
    http::async_write(this->Socket, *shared,
      [self = this->shared_from_this(), shared](beast::error_code error, std::size_t) {
        if (error || !shared->keep_alive())
        {
          self->Close();
          return;
        }
        self->Read();
      });
  }

  void Close();

  std::shared_ptr<RemotingServer::Internals> Server;
  Stream Socket;
  beast::flat_buffer Buffer;
  std::optional<http::request_parser<http::string_body>> Parser;
};

template <>
void HttpSession<beast::tcp_stream>::Close()
{
  beast::error_code ignored;
  this->Socket.socket().shutdown(tcp::socket::shutdown_send, ignored);
}

template <>
void HttpSession<beast::ssl_stream<beast::tcp_stream>>::Close()
{
  beast::get_lowest_layer(this->Socket).expires_after(std::chrono::seconds(5));
  this->Socket.async_shutdown([self = this->shared_from_this()](beast::error_code) {});
}

void RemotingServer::Internals::Accept()
{
  this->Acceptor->async_accept(net::make_strand(*this->Io),
    [self = this->shared_from_this()](beast::error_code error, tcp::socket socket) {
      if (error)
      {
        if (error != net::error::operation_aborted)
        {
          self->Log(std::string("accept failed: ") + error.message());
          self->Accept();
        }
        return;
      }
      if (!self->Options.allowRemoteConnections)
      {
        beast::error_code ignored;
        const auto remote = socket.remote_endpoint(ignored);
        if (ignored || !IsLoopback(remote.address()))
        {
          self->Log("refused a connection from " + remote.address().to_string() +
            " (remote connections are off)");
          self->Accept();
          return;
        }
      }
      if (self->TlsContext)
      {
        auto stream = std::make_shared<beast::ssl_stream<beast::tcp_stream>>(
          beast::tcp_stream(std::move(socket)), *self->TlsContext);
        beast::get_lowest_layer(*stream).expires_after(std::chrono::seconds(30));
        stream->async_handshake(ssl::stream_base::server,
          [self, stream](beast::error_code handshakeError) {
            if (handshakeError)
            {
              self->Log(std::string("TLS handshake failed: ") + handshakeError.message());
              return;
            }
            std::make_shared<HttpSession<beast::ssl_stream<beast::tcp_stream>>>(
              self, std::move(*stream))
              ->Read();
          });
      }
      else
      {
        std::make_shared<HttpSession<beast::tcp_stream>>(self, beast::tcp_stream(std::move(socket)))
          ->Read();
      }
      self->Accept();
    });
}

std::string GenerateAccessToken()
{
  unsigned char bytes[16];
  if (RAND_bytes(bytes, sizeof(bytes)) != 1)
  {
    // OpenSSL's generator is seeded from the kernel; failing here means no entropy at all.
    throw std::runtime_error("OpenSSL could not generate random bytes for the access token");
  }
  static const char* const digits = "0123456789abcdef";
  std::string token;
  for (unsigned char byte : bytes)
  {
    token.push_back(digits[byte >> 4]);
    token.push_back(digits[byte & 15]);
  }
  return token;
}

RemotingServer::RemotingServer(ServerOptions options)
  : Impl(std::make_shared<Internals>())
{
  this->Impl->Options = std::move(options);
  if (this->Impl->Options.accessToken.empty())
  {
    this->Impl->Options.accessToken = GenerateAccessToken();
  }
}

RemotingServer::~RemotingServer()
{
  this->Stop();
}

bool RemotingServer::Start(std::string* reason)
{
  Internals& impl = *this->Impl;
  if (impl.Running)
  {
    return true;
  }
  beast::error_code error;
  const net::ip::address address = net::ip::make_address(impl.Options.bindAddress, error);
  if (error)
  {
    *reason = "'" + impl.Options.bindAddress + "' is not an IP address to listen on";
    return false;
  }
  if (!IsLoopback(address) && !impl.Options.allowRemoteConnections)
  {
    *reason = "listening on " + impl.Options.bindAddress +
      " would let other machines connect; allow remote connections explicitly (holovolume "
      "--serve --allow-remote) or keep the default 127.0.0.1";
    return false;
  }
  if (impl.Options.accessToken.size() < 16)
  {
    *reason = "the access token must have at least 16 characters";
    return false;
  }
  if (impl.Options.certificateFile.empty() != impl.Options.privateKeyFile.empty())
  {
    *reason = "TLS needs both a certificate file and a private key file";
    return false;
  }
  if (!impl.Options.certificateFile.empty())
  {
    impl.TlsContext = std::make_unique<ssl::context>(ssl::context::tls_server);
    impl.TlsContext->set_options(ssl::context::default_workarounds | ssl::context::no_sslv2 |
      ssl::context::no_sslv3 | ssl::context::no_tlsv1 | ssl::context::no_tlsv1_1);
    impl.TlsContext->use_certificate_chain_file(impl.Options.certificateFile, error);
    if (error)
    {
      *reason = "cannot use the TLS certificate '" + impl.Options.certificateFile +
        "' (a PEM certificate chain): " + error.message();
      return false;
    }
    impl.TlsContext->use_private_key_file(impl.Options.privateKeyFile, ssl::context::pem, error);
    if (error)
    {
      *reason = "cannot use the TLS private key '" + impl.Options.privateKeyFile +
        "' (PEM, matching the certificate): " + error.message();
      return false;
    }
  }
  std::ifstream page(impl.Options.webRoot + "/index.html");
  if (!page)
  {
    *reason = "the player page is missing: no index.html in '" + impl.Options.webRoot + "'";
    return false;
  }
  impl.Acceptor = std::make_unique<tcp::acceptor>(net::make_strand(*impl.Io));
  const tcp::endpoint endpoint(address, impl.Options.port);
  impl.Acceptor->open(endpoint.protocol(), error);
  if (!error)
  {
    impl.Acceptor->set_option(net::socket_base::reuse_address(true), error);
  }
  if (!error)
  {
    impl.Acceptor->bind(endpoint, error);
  }
  if (!error)
  {
    impl.Acceptor->listen(net::socket_base::max_listen_connections, error);
  }
  if (error)
  {
    *reason = "cannot listen on " + impl.Options.bindAddress + ":" +
      std::to_string(impl.Options.port) + ": " + error.message() +
      " (choose another port, or 0 for any free one)";
    impl.Acceptor.reset();
    return false;
  }
  impl.Port = impl.Acceptor->local_endpoint().port();
  impl.Running = true;
  impl.Accept();
  impl.NetworkThread = std::thread([this] { this->Impl->Io->run(); });
  return true;
}

void RemotingServer::Stop()
{
  Internals& impl = *this->Impl;
  if (!impl.Running)
  {
    return;
  }
  impl.Io->stop();
  if (impl.NetworkThread.joinable())
  {
    impl.NetworkThread.join();
  }
  // Destroying the io_context destroys the handlers still queued, and with them the sessions
  // they hold (which hold this server): that closes the sockets and breaks the cycle.
  impl.Acceptor.reset();
  impl.Io = std::make_unique<net::io_context>(1);
  {
    std::lock_guard<std::mutex> lock(impl.Mutex);
    impl.Controller = nullptr;
  }
  impl.Running = false;
}

bool RemotingServer::IsRunning() const
{
  return this->Impl->Running;
}

unsigned short RemotingServer::GetPort() const
{
  return this->Impl->Port;
}

const std::string& RemotingServer::GetAccessToken() const
{
  return this->Impl->Options.accessToken;
}

bool RemotingServer::UsesTls() const
{
  return this->Impl->TlsContext != nullptr;
}

std::string RemotingServer::GetUrl() const
{
  const Internals& impl = *this->Impl;
  std::string host = impl.Options.bindAddress;
  if (host == "0.0.0.0" || host == "::")
  {
    host = net::ip::host_name();
  }
  else if (host.find(':') != std::string::npos)
  {
    host = "[" + host + "]";
  }
  return std::string(impl.TlsContext ? "https://" : "http://") + host + ":" +
    std::to_string(impl.Port) + "/?token=" + impl.Options.accessToken;
}

void RemotingServer::SetWelcome(const WelcomeInfo& welcome)
{
  std::lock_guard<std::mutex> lock(this->Impl->Mutex);
  this->Impl->Welcome = welcome;
}

bool RemotingServer::TakeNewestPose(PoseMessage* pose)
{
  std::lock_guard<std::mutex> lock(this->Impl->Mutex);
  if (!this->Impl->HasNewPose)
  {
    return false;
  }
  *pose = this->Impl->NewestPose;
  this->Impl->HasNewPose = false;
  return true;
}

std::vector<InteractionMessage> RemotingServer::TakeInteractions()
{
  std::lock_guard<std::mutex> lock(this->Impl->Mutex);
  std::vector<InteractionMessage> interactions(
    this->Impl->Interactions.begin(), this->Impl->Interactions.end());
  this->Impl->Interactions.clear();
  return interactions;
}

void RemotingServer::WaitForActivity(double seconds)
{
  std::unique_lock<std::mutex> lock(this->Impl->Mutex);
  this->Impl->Activity.wait_for(lock, std::chrono::duration<double>(seconds),
    [this] { return this->Impl->ActivitySignalled; });
  this->Impl->ActivitySignalled = false;
}

bool RemotingServer::NeedsCodec(Codec codec) const
{
  std::lock_guard<std::mutex> lock(this->Impl->Mutex);
  for (const auto& weak : this->Impl->Sessions)
  {
    const auto session = weak.lock();
    if (session && session->Greeted && session->SessionCodec == codec)
    {
      return true;
    }
  }
  return false;
}

bool RemotingServer::TakeKeyFrameRequest()
{
  std::lock_guard<std::mutex> lock(this->Impl->Mutex);
  const bool requested = this->Impl->KeyFrameRequested;
  this->Impl->KeyFrameRequested = false;
  return requested;
}

void RemotingServer::Publish(const PublishedFrame& frame)
{
  std::vector<std::shared_ptr<ClientSession>> sessions;
  {
    std::lock_guard<std::mutex> lock(this->Impl->Mutex);
    for (const auto& weak : this->Impl->Sessions)
    {
      if (auto session = weak.lock())
      {
        sessions.push_back(std::move(session));
      }
    }
  }
  const double publishedMs = NowMs();
  // The network thread owns the sessions' write state: hand the frame over, never block.
  net::post(*this->Impl->Io, [sessions = std::move(sessions), frame, publishedMs] {
    for (const auto& session : sessions)
    {
      session->QueueFrame(frame, publishedMs);
    }
  });
}

bool RemotingServer::Flush(double timeoutSeconds)
{
  if (!this->IsRunning())
  {
    return false;
  }
  // Handlers run in the order they were queued on the one network thread: when this one runs,
  // everything published before it has been handed to the sessions.
  auto done = std::make_shared<std::promise<void>>();
  std::future<void> handled = done->get_future();
  net::post(*this->Impl->Io, [done] { done->set_value(); });
  return handled.wait_for(std::chrono::duration<double>(timeoutSeconds)) ==
    std::future_status::ready;
}

void RemotingServer::PublishStatistics(const ServerStatistics& statistics)
{
  std::vector<std::shared_ptr<ClientSession>> sessions;
  ServerStatistics filled = statistics;
  {
    std::lock_guard<std::mutex> lock(this->Impl->Mutex);
    for (const auto& weak : this->Impl->Sessions)
    {
      if (auto session = weak.lock())
      {
        sessions.push_back(std::move(session));
      }
    }
    filled.poseToDisplayMs = this->Impl->Counters.poseToDisplayMs;
    filled.clients = static_cast<int>(sessions.size());
  }
  net::post(*this->Impl->Io, [sessions = std::move(sessions), filled] {
    for (const auto& session : sessions)
    {
      session->QueueStatistics(filled);
    }
  });
}

ServerCounters RemotingServer::GetCounters() const
{
  std::lock_guard<std::mutex> lock(this->Impl->Mutex);
  ServerCounters counters = this->Impl->Counters;
  counters.clients = 0;
  counters.spectators = 0;
  for (const auto& weak : this->Impl->Sessions)
  {
    const auto session = weak.lock();
    if (session && session->Greeted)
    {
      ++counters.clients;
      counters.spectators += session->SessionRole == Role::Spectator ? 1 : 0;
    }
  }
  counters.hasController = this->Impl->Controller != nullptr;
  return counters;
}
}
}
