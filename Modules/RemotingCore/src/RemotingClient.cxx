// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/remoting/RemotingClient.h"

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/beast/websocket/ssl.hpp>

#include <cctype>
#include <chrono>
#include <optional>
#include <variant>

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
using PlainSocket = websocket::stream<beast::tcp_stream>;
using TlsSocket = websocket::stream<beast::ssl_stream<beast::tcp_stream>>;

std::chrono::nanoseconds Seconds(double seconds)
{
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::duration<double>(seconds));
}

// Runs the io_context until `done` or the timeout; true when done.
bool RunUntil(net::io_context& io, const bool& done, double timeoutSeconds)
{
  const auto deadline = std::chrono::steady_clock::now() + Seconds(timeoutSeconds);
  io.restart();
  while (!done && std::chrono::steady_clock::now() < deadline)
  {
    io.run_one_until(deadline);
    if (io.stopped() && !done)
    {
      io.restart();
    }
  }
  return done;
}
}

struct RemotingClient::Internals
{
  net::io_context Io;
  ssl::context Tls{ ssl::context::tls_client };
  std::variant<std::monostate, std::unique_ptr<PlainSocket>, std::unique_ptr<TlsSocket>> Socket;
  beast::flat_buffer Buffer;
  bool ReadPending = false;
  bool ReadDone = false;
  beast::error_code ReadError;
  bool ReadText = false;
  int CloseCode = 0;

  template <class Function>
  auto With(Function&& function)
  {
    if (auto* plain = std::get_if<std::unique_ptr<PlainSocket>>(&this->Socket))
    {
      return function(**plain);
    }
    return function(*std::get<std::unique_ptr<TlsSocket>>(this->Socket));
  }
};

RemotingClient::RemotingClient()
  : Impl(std::make_unique<Internals>())
{
  this->Impl->Tls.set_verify_mode(ssl::verify_none);
}

RemotingClient::~RemotingClient()
{
  this->Close();
}

bool RemotingClient::Connect(const std::string& host, unsigned short port,
  const std::string& target, bool tls, std::string* reason, double timeoutSeconds)
{
  Internals& impl = *this->Impl;
  tcp::resolver resolver(impl.Io);
  beast::error_code error;
  const auto endpoints = resolver.resolve(host, std::to_string(port), error);
  if (error)
  {
    *reason = "cannot resolve " + host + ": " + error.message();
    return false;
  }
  bool done = false;
  beast::error_code stepError;
  websocket::response_type response;
  const std::string hostHeader = host + ":" + std::to_string(port);
  const auto handshake = [&](auto& socket) {
    socket.async_handshake(response, hostHeader, target, [&](beast::error_code e) {
      stepError = e;
      done = true;
    });
  };
  if (tls)
  {
    impl.Socket = std::make_unique<TlsSocket>(impl.Io, impl.Tls);
    TlsSocket* socket = std::get<std::unique_ptr<TlsSocket>>(impl.Socket).get();
    beast::get_lowest_layer(*socket).expires_after(Seconds(timeoutSeconds));
    // The handlers capture the socket pointer by value: this block ends before they run.
    beast::get_lowest_layer(*socket).async_connect(
      endpoints, [&, socket](beast::error_code e, const tcp::endpoint&) {
        if (e)
        {
          stepError = e;
          done = true;
          return;
        }
        socket->next_layer().async_handshake(ssl::stream_base::client, [&, socket](beast::error_code e2) {
          if (e2)
          {
            stepError = e2;
            done = true;
            return;
          }
          beast::get_lowest_layer(*socket).expires_never();
          handshake(*socket);
        });
      });
  }
  else
  {
    impl.Socket = std::make_unique<PlainSocket>(impl.Io);
    PlainSocket* socket = std::get<std::unique_ptr<PlainSocket>>(impl.Socket).get();
    beast::get_lowest_layer(*socket).expires_after(Seconds(timeoutSeconds));
    beast::get_lowest_layer(*socket).async_connect(
      endpoints, [&, socket](beast::error_code e, const tcp::endpoint&) {
        if (e)
        {
          stepError = e;
          done = true;
          return;
        }
        beast::get_lowest_layer(*socket).expires_never();
        handshake(*socket);
      });
  }
  if (!RunUntil(impl.Io, done, timeoutSeconds))
  {
    *reason = "connecting timed out";
    impl.Socket = std::monostate();
    return false;
  }
  if (stepError)
  {
    *reason = stepError.message();
    if (response.result_int() != 0)
    {
      *reason += " (HTTP " + std::to_string(response.result_int()) + ")";
    }
    impl.Socket = std::monostate();
    return false;
  }
  impl.With([](auto& socket) {
    socket.set_option(websocket::stream_base::timeout::suggested(beast::role_type::client));
    socket.read_message_max(256u << 20);
  });
  return true;
}

bool RemotingClient::SendText(const std::string& text, std::string* reason)
{
  if (std::holds_alternative<std::monostate>(this->Impl->Socket))
  {
    *reason = "not connected";
    return false;
  }
  beast::error_code error;
  this->Impl->With([&](auto& socket) {
    socket.text(true);
    socket.write(net::buffer(text), error);
  });
  if (error)
  {
    *reason = error.message();
    return false;
  }
  return true;
}

bool RemotingClient::SendBinary(const std::string& bytes, std::string* reason)
{
  if (std::holds_alternative<std::monostate>(this->Impl->Socket))
  {
    *reason = "not connected";
    return false;
  }
  beast::error_code error;
  this->Impl->With([&](auto& socket) {
    socket.binary(true);
    socket.write(net::buffer(bytes), error);
  });
  if (error)
  {
    *reason = error.message();
    return false;
  }
  return true;
}

RemotingClient::Received RemotingClient::Receive(
  std::string* message, double timeoutSeconds, std::string* reason)
{
  Internals& impl = *this->Impl;
  if (std::holds_alternative<std::monostate>(impl.Socket))
  {
    *reason = "not connected";
    return Received::Failed;
  }
  if (!impl.ReadPending)
  {
    impl.ReadPending = true;
    impl.ReadDone = false;
    impl.With([&](auto& socket) {
      socket.async_read(impl.Buffer, [&impl, &socket](beast::error_code error, std::size_t) {
        impl.ReadError = error;
        impl.ReadText = socket.got_text();
        if (error == websocket::error::closed)
        {
          impl.CloseCode = socket.reason().code;
        }
        impl.ReadDone = true;
      });
    });
  }
  if (!RunUntil(impl.Io, impl.ReadDone, timeoutSeconds))
  {
    return Received::Timeout;
  }
  impl.ReadPending = false;
  if (impl.ReadError)
  {
    if (impl.ReadError == websocket::error::closed)
    {
      return Received::Closed;
    }
    *reason = impl.ReadError.message();
    return Received::Failed;
  }
  *message = beast::buffers_to_string(impl.Buffer.data());
  impl.Buffer.consume(impl.Buffer.size());
  return impl.ReadText ? Received::Text : Received::Binary;
}

int RemotingClient::GetCloseCode() const
{
  return this->Impl->CloseCode;
}

void RemotingClient::Close()
{
  Internals& impl = *this->Impl;
  if (std::holds_alternative<std::monostate>(impl.Socket))
  {
    return;
  }
  bool done = false;
  impl.With([&](auto& socket) {
    if (socket.is_open())
    {
      socket.async_close(websocket::close_code::normal, [&](beast::error_code) { done = true; });
    }
    else
    {
      done = true;
    }
  });
  RunUntil(impl.Io, done, 2.0);
  impl.Socket = std::monostate();
  impl.ReadPending = false;
}

bool HttpGet(const std::string& host, unsigned short port, const std::string& target, bool tls,
  const std::map<std::string, std::string>& extraHeaders, HttpResult* result, std::string* reason)
{
  net::io_context io;
  ssl::context context(ssl::context::tls_client);
  context.set_verify_mode(ssl::verify_none);
  tcp::resolver resolver(io);
  beast::error_code error;
  const auto endpoints = resolver.resolve(host, std::to_string(port), error);
  if (error)
  {
    *reason = error.message();
    return false;
  }
  http::request<http::empty_body> request{ http::verb::get, target, 11 };
  request.set(http::field::host, host + ":" + std::to_string(port));
  for (const auto& [name, value] : extraHeaders)
  {
    request.set(name, value);
  }
  http::response<http::string_body> response;
  beast::flat_buffer buffer;
  const auto exchange = [&](auto& stream) {
    http::write(stream, request, error);
    if (!error)
    {
      http::read(stream, buffer, response, error);
    }
  };
  if (tls)
  {
    beast::ssl_stream<beast::tcp_stream> stream(io, context);
    beast::get_lowest_layer(stream).connect(endpoints, error);
    if (!error)
    {
      stream.handshake(ssl::stream_base::client, error);
    }
    if (!error)
    {
      exchange(stream);
    }
  }
  else
  {
    beast::tcp_stream stream(io);
    stream.connect(endpoints, error);
    if (!error)
    {
      exchange(stream);
    }
  }
  if (error)
  {
    *reason = error.message();
    return false;
  }
  result->status = response.result_int();
  result->body = response.body();
  result->headers.clear();
  for (const auto& field : response)
  {
    std::string name(field.name_string());
    for (char& c : name)
    {
      c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    }
    result->headers[name] = std::string(field.value());
  }
  return true;
}
}
}
