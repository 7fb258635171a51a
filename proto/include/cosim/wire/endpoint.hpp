#pragma once
// Where the coupler listens. ipc:// inside the run directory is the default on
// one host; tcp:// is opt-in and binds to loopback unless an interface is named.
#include <filesystem>
#include <string>

namespace cosim::wire {

struct TransportOptions {
  enum class Kind { ipc, tcp } kind = Kind::ipc;
  std::string interface = "127.0.0.1";  // tcp: address or interface to bind
  int port = 0;                          // tcp: 0 = any free port
  bool curve = false;                    // tcp: CurveZMQ encryption with a per-run server key
};

/// The endpoint string the coupler binds. For ipc the socket lives in runDir;
/// when that path is too long for a Unix socket (about 107 bytes), a private
/// 0700 directory under the system temp dir is used instead.
std::string bindEndpoint(const TransportOptions& transport, const std::filesystem::path& runDir);

/// For an endpoint that the coupler bound to a wildcard (tcp "*" or 0.0.0.0),
/// the address a peer on this host should connect to.
std::string connectableEndpoint(const std::string& boundEndpoint);

/// The same for peers that may run on another host (Slurm job steps): this
/// host's name instead of the wildcard.
std::string connectableFromAnyHost(const std::string& boundEndpoint);

/// This host's name (gethostname), as a solver's hello names its host.
std::string thisHostName();

/// Removes an ipc socket file (and its private temp dir) after the run.
void removeIpcEndpoint(const std::string& endpoint);

}  // namespace cosim::wire
