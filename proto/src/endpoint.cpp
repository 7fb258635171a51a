#include "cosim/wire/endpoint.hpp"

#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdlib>
#include <stdexcept>
#include <system_error>

namespace cosim::wire {
namespace fs = std::filesystem;

namespace {
constexpr std::size_t kMaxUnixPath = sizeof(sockaddr_un::sun_path) - 1;
constexpr const char* kPrivateTemplate = "cosim-ipc-XXXXXX";
}  // namespace

std::string bindEndpoint(const TransportOptions& t, const fs::path& runDir) {
  if (t.kind == TransportOptions::Kind::tcp) {
    const std::string port = t.port == 0 ? "*" : std::to_string(t.port);
    return "tcp://" + t.interface + ":" + port;
  }
  fs::path socket = fs::absolute(runDir) / "coupler.sock";
  if (socket.string().size() > kMaxUnixPath) {
    std::string dir = (fs::temp_directory_path() / kPrivateTemplate).string();
    if (::mkdtemp(dir.data()) == nullptr)
      throw std::system_error(errno, std::generic_category(), "mkdtemp for the ipc endpoint");
    socket = fs::path(dir) / "coupler.sock";
  }
  return "ipc://" + socket.string();
}

std::string connectableEndpoint(const std::string& bound) {
  const std::string wildcard = "tcp://0.0.0.0:";
  if (bound.rfind(wildcard, 0) == 0) return "tcp://127.0.0.1:" + bound.substr(wildcard.size());
  return bound;
}

std::string thisHostName() {
  char host[256] = {};
  if (::gethostname(host, sizeof(host) - 1) != 0) return {};
  return host;
}

std::string connectableFromAnyHost(const std::string& bound) {
  const std::string wildcard = "tcp://0.0.0.0:";
  if (bound.rfind(wildcard, 0) != 0) return bound;
  const std::string host = thisHostName();
  if (host.empty()) return connectableEndpoint(bound);
  return "tcp://" + std::string(host) + ":" + bound.substr(wildcard.size());
}

void removeIpcEndpoint(const std::string& endpoint) {
  const std::string scheme = "ipc://";
  if (endpoint.rfind(scheme, 0) != 0) return;
  const fs::path socket = endpoint.substr(scheme.size());
  std::error_code ec;
  fs::remove(socket, ec);
  const auto dir = socket.parent_path();
  if (dir.filename().string().rfind("cosim-ipc-", 0) == 0) fs::remove(dir, ec);
}

}  // namespace cosim::wire
