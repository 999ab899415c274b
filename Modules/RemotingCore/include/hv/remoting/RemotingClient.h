// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// A C++ client of the remoting protocol on Boost.Beast (plain or TLS): the loopback tests and
// the streaming benchmark use it in place of the browser. Calls block, with timeouts.
#ifndef hv_remoting_RemotingClient_h
#define hv_remoting_RemotingClient_h

#include <map>
#include <memory>
#include <string>

namespace hv
{
namespace remoting
{
class RemotingClient
{
public:
  RemotingClient();
  ~RemotingClient();
  RemotingClient(const RemotingClient&) = delete;
  RemotingClient& operator=(const RemotingClient&) = delete;

  // Opens the WebSocket at `target` (e.g. "/ws?token=..."). With tls the server's certificate
  // is not verified (tests use a self-signed one). On a refused upgrade, reason holds the
  // HTTP status.
  bool Connect(const std::string& host, unsigned short port, const std::string& target, bool tls,
    std::string* reason, double timeoutSeconds = 10.0);
  bool SendText(const std::string& text, std::string* reason);
  // Sends raw bytes as one binary message (tests of the server's rejection).
  bool SendBinary(const std::string& bytes, std::string* reason);

  enum class Received
  {
    Text,
    Binary,
    Closed,
    Timeout,
    Failed
  };
  // The next message; a read that times out stays pending and completes in a later call.
  Received Receive(std::string* message, double timeoutSeconds, std::string* reason);
  // The close code the server sent (valid after Receive returned Closed).
  int GetCloseCode() const;
  void Close();

private:
  struct Internals;
  std::unique_ptr<Internals> Impl;
};

struct HttpResult
{
  int status = 0;
  std::string body;
  std::map<std::string, std::string> headers; // lower-case names
};

// One HTTP/1.1 GET (no redirects); extraHeaders such as {"cookie", "..."}.
bool HttpGet(const std::string& host, unsigned short port, const std::string& target, bool tls,
  const std::map<std::string, std::string>& extraHeaders, HttpResult* result, std::string* reason);
}
}

#endif
