#include "client/cli/connection_options.h"

#include <CLI/CLI.hpp>

namespace mm::client {

void add_connection_options(CLI::App& app, ConnectionOptions& options) {
  app.add_option("--server", options.server, "gRPC server host:port")->envname("MM_SERVER")->capture_default_str();
  app.add_flag("--rest", options.rest, "talk REST/JSON instead of gRPC");
  app.add_option("--rest-url", options.rest_url, "REST base URL (with --rest)")->envname("MM_REST_URL")
      ->capture_default_str();
  app.add_option("--token", options.token,
                 "bearer token of a server started with one, for the calls that change its state (models activate "
                 "and delete, clips upload and delete, jobs submit, cancel and delete) and clips list and read; "
                 "empty (a server without a token, called from its own machine): none is sent")
      ->envname("MM_TOKEN");
  app.add_option("--tls-ca", options.tls_ca, "PEM CA certificate of the server; turns TLS on")
      ->envname("MM_TLS_CA")->check(CLI::ExistingFile);
  app.add_flag("--tls", options.tls, "TLS with the system's root certificates (or --tls-ca)");
  app.add_option("--timeout", options.timeout_seconds, "seconds to wait for one call")
      ->check(CLI::Range(0.1, 86400.0))->capture_default_str();
}

}  // namespace mm::client
