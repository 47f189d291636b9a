#include "client/cli/server_connection.h"

namespace mm::client {

std::unique_ptr<ServerConnection> connect(const ConnectionOptions& options) {
  return options.rest ? rest_connection(options) : grpc_connection(options);
}

bool is_final_state(const std::string& state) {
  return state == "succeeded" || state == "failed" || state == "cancelled";
}

}  // namespace mm::client
