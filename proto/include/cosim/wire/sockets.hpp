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

/// A CurveZMQ key pair in Z85 text (40 characters each).
struct CurveKeyPair {
  std::string publicKey;
  std::string secretKey;
  static CurveKeyPair generate();
};

class RouterSocket {
 public:
  /// With a server key pair, the socket speaks CurveZMQ: traffic is
  /// encrypted and only peers that know the public key can connect.
  explicit RouterSocket(const std::string& bindEndpoint, const std::optional<CurveKeyPair>& curve = std::nullopt);
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
  /// serverPublicKey (Z85): connect with CurveZMQ to a coupler that uses it.
  DealerSocket(const std::string& connectEndpoint, const std::string& identity,
               const std::string& serverPublicKey = {});
  void send(const OutMessage& message);
  std::optional<Received> receive(std::chrono::milliseconds timeout);
  zmq::socket_t& raw() { return socket_; }

 private:
  zmq::socket_t socket_;
};

/// Receives every frame of one multipart message that is already waiting.
std::vector<zmq::message_t> receiveMultipart(zmq::socket_t& socket);

}  // namespace cosim::wire
