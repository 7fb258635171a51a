#pragma once
// The two socket roles: the coupler binds one ROUTER, each solver connects a
// DEALER whose routing id is its instance name. No REQ/REP lock-step: a lost
// or garbled message cannot wedge either side.
#include <chrono>
#include <optional>
#include <string>
#include <zmq.hpp>

#include "cosim/wire/message.hpp"

namespace cosim::wire {

/// One received message: a decoded Envelope, or why decoding failed.
struct Received {
  std::string identity;  // ROUTER side: who sent it
  std::optional<InMessage> message;
  std::string error;     // set when message is empty
  std::size_t bytes = 0;
};

/// The one context every socket of a process shares.
zmq::context_t& context();

class RouterSocket {
 public:
  explicit RouterSocket(const std::string& bindEndpoint);
  /// The endpoint actually bound (a tcp wildcard port resolved).
  const std::string& endpoint() const { return endpoint_; }
  /// False when no peer of that identity is connected.
  bool send(const std::string& identity, const OutMessage& message);
  std::optional<Received> receive(std::chrono::milliseconds timeout);
  zmq::socket_t& raw() { return socket_; }

 private:
  zmq::socket_t socket_;
  std::string endpoint_;
};

class DealerSocket {
 public:
  DealerSocket(const std::string& connectEndpoint, const std::string& identity);
  void send(const OutMessage& message);
  std::optional<Received> receive(std::chrono::milliseconds timeout);
  zmq::socket_t& raw() { return socket_; }

 private:
  zmq::socket_t socket_;
};

/// Receives every frame of one multipart message that is already waiting.
std::vector<zmq::message_t> receiveMultipart(zmq::socket_t& socket);

}  // namespace cosim::wire
