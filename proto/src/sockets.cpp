#include "cosim/wire/sockets.hpp"

namespace cosim::wire {
namespace {

constexpr int kLingerMs = 2000;      // let a last reply leave before a process exits
constexpr int kSendTimeoutMs = 30000; // a peer that takes nothing for this long is gone
constexpr int kHighWaterMark = 100000;
// The largest frame a socket takes in (one Cap'n Proto segment; payloads of a
// few hundred MiB are tested). A frame header that claims more, garbage from
// anyone who reaches the endpoint, ends that connection before libzmq
// allocates the claimed size.
constexpr std::int64_t kMaxFrameBytes = std::int64_t{4} << 30;

void configure(zmq::socket_t& s) {
  s.set(zmq::sockopt::linger, kLingerMs);
  s.set(zmq::sockopt::sndtimeo, kSendTimeoutMs);
  s.set(zmq::sockopt::sndhwm, kHighWaterMark);
  s.set(zmq::sockopt::rcvhwm, kHighWaterMark);
  s.set(zmq::sockopt::maxmsgsize, kMaxFrameBytes);
}

bool sendFrames(zmq::socket_t& socket, std::vector<zmq::message_t>& frames) {
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const auto flags = i + 1 < frames.size() ? zmq::send_flags::sndmore : zmq::send_flags::none;
    if (!socket.send(frames[i], flags)) return false;
  }
  return true;
}

Received decodeFrames(std::vector<zmq::message_t>&& frames, std::string identity) {
  Received r;
  r.identity = std::move(identity);
  for (const auto& f : frames) r.bytes += f.size();
  try {
    r.message.emplace(InMessage::decode(std::move(frames)));
  } catch (const MalformedMessage& e) {
    r.error = e.what();
  }
  return r;
}

bool waitReadable(zmq::socket_t& socket, std::chrono::milliseconds timeout) {
  zmq::pollitem_t item{socket.handle(), 0, ZMQ_POLLIN, 0};
  try {
    return zmq::poll(&item, 1, timeout) > 0;
  } catch (const zmq::error_t& e) {
    if (e.num() == EINTR) return false;  // a signal: the caller decides what it means
    throw;
  }
}

}  // namespace

zmq::context_t& context() {
  static zmq::context_t ctx(1);
  return ctx;
}

std::vector<zmq::message_t> receiveMultipart(zmq::socket_t& socket) {
  std::vector<zmq::message_t> frames;
  do {
    zmq::message_t frame;
    if (!socket.recv(frame, zmq::recv_flags::dontwait)) break;
    frames.push_back(std::move(frame));
  } while (socket.get(zmq::sockopt::rcvmore));
  return frames;
}

CurveKeyPair CurveKeyPair::generate() {
  char pub[41] = {};
  char sec[41] = {};
  if (zmq_curve_keypair(pub, sec) != 0)
    throw std::runtime_error("CurveZMQ is not available in this libzmq build (zmq_curve_keypair failed)");
  return {pub, sec};
}

RouterSocket::RouterSocket(const std::string& bindEndpoint, const std::optional<CurveKeyPair>& curve)
    : socket_(context(), zmq::socket_type::router) {
  configure(socket_);
  if (curve) {
    socket_.set(zmq::sockopt::curve_server, 1);
    socket_.set(zmq::sockopt::curve_secretkey, curve->secretKey);
  }
  socket_.set(zmq::sockopt::router_mandatory, 1);
  socket_.bind(bindEndpoint);
  endpoint_ = socket_.get(zmq::sockopt::last_endpoint);
}

bool RouterSocket::send(const std::string& identity, const OutMessage& message) {
  auto frames = message.frames();
  try {
    zmq::message_t id(identity.data(), identity.size());
    if (!socket_.send(id, zmq::send_flags::sndmore)) return false;
    return sendFrames(socket_, frames);
  } catch (const zmq::error_t& e) {
    if (e.num() == EHOSTUNREACH) return false;
    throw;
  }
}

std::optional<Received> RouterSocket::receive(std::chrono::milliseconds timeout) {
  if (!waitReadable(socket_, timeout)) return std::nullopt;
  auto frames = receiveMultipart(socket_);
  if (frames.empty()) return std::nullopt;
  std::string identity(static_cast<const char*>(frames.front().data()), frames.front().size());
  frames.erase(frames.begin());
  return decodeFrames(std::move(frames), std::move(identity));
}

DealerSocket::DealerSocket(const std::string& connectEndpoint, const std::string& identity,
                           const std::string& serverPublicKey)
    : socket_(context(), zmq::socket_type::dealer) {
  configure(socket_);
  if (!serverPublicKey.empty()) {
    if (serverPublicKey.size() != 40)
      throw std::invalid_argument("a CurveZMQ server key is 40 Z85 characters, got " +
                                  std::to_string(serverPublicKey.size()));
    const auto mine = CurveKeyPair::generate();  // this connection's own key pair
    socket_.set(zmq::sockopt::curve_serverkey, serverPublicKey);
    socket_.set(zmq::sockopt::curve_publickey, mine.publicKey);
    socket_.set(zmq::sockopt::curve_secretkey, mine.secretKey);
  }
  socket_.set(zmq::sockopt::routing_id, identity);
  socket_.connect(connectEndpoint);
}

void DealerSocket::send(const OutMessage& message) {
  auto frames = message.frames();
  if (!sendFrames(socket_, frames))
    throw std::runtime_error("send to the coupler timed out");
}

std::optional<Received> DealerSocket::receive(std::chrono::milliseconds timeout) {
  if (!waitReadable(socket_, timeout)) return std::nullopt;
  auto frames = receiveMultipart(socket_);
  if (frames.empty()) return std::nullopt;
  return decodeFrames(std::move(frames), {});
}

}  // namespace cosim::wire
