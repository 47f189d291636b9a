// Where the server is and how to reach it: flags, else the environment
// (MM_SERVER, MM_REST_URL, MM_TOKEN, MM_TLS_CA), else the defaults, so that
// a shell can set them once for many commands.
#pragma once

#include <string>

namespace CLI {
class App;
}

namespace mm::client {

struct ConnectionOptions {
  std::string server = "localhost:50051";      // gRPC host:port
  std::string rest_url = "http://localhost:8080";  // REST base URL
  bool rest = false;                           // use REST instead of gRPC
  std::string token;                           // bearer token, for the calls that change state
  std::string tls_ca;                          // PEM CA file; turns TLS on
  bool tls = false;                            // TLS with the system's roots (or tls_ca)
  double timeout_seconds = 300;                // per unary call
};

// Adds the connection flags to `app` (for every command), with the
// environment variables as their fallbacks.
void add_connection_options(CLI::App& app, ConnectionOptions& options);

// Whether the connection is encrypted (--tls or a CA given).
inline bool uses_tls(const ConnectionOptions& options) { return options.tls || !options.tls_ca.empty(); }

}  // namespace mm::client
